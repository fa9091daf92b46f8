// SPDX-License-Identifier: MIT
// lidarflow sequence: scene flow for every consecutive frame pair of a recorded drive in the
// KITTI raw layout (image_02/data, image_03/data, velodyne_points/data, calib_*.txt), streamed
// through one estimator as the C ABI streams pushed frames, so each frame's work is reused by
// the next pair. Bad frames are reported and only their pairs are skipped.
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "log.hpp"
#include "result_files.hpp"
#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/image_file.hpp"
#include "io/output_folder.hpp"
#include "io/velo_to_left.hpp"
#include "io/velodyne.hpp"
#include "lidar/projection.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/option_assignments.hpp"

namespace lidarflow::cli {
namespace {

namespace fs = std::filesystem;

constexpr int kExitBadFrames = 3;  // as the bridge's --replay for lost frames
constexpr long kMaxPairs = 1000000;  // 28 hours at 10 Hz

std::string frame_name(long k) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "%010ld", k);
    return buf;
}

// A drive's frames: the 10-digit numbers of image_02/data/*.png, sorted.
std::vector<long> list_frames(const fs::path &root) {
    const fs::path dir = root / "image_02" / "data";
    std::error_code ec;
    require(fs::is_directory(dir, ec), ErrorCode::Io,
            "sequence: " + dir.string() + " is not a folder (expected the KITTI raw layout: image_02/data, "
            "image_03/data, velodyne_points/data)");
    std::vector<long> frames;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.size() != 14 || name.substr(10) != ".png" ||
            !std::all_of(name.begin(), name.begin() + 10, [](unsigned char c) { return std::isdigit(c); }))
            continue;
        frames.push_back(std::stol(name.substr(0, 10)));
    }
    require(!ec, ErrorCode::Io, "sequence: cannot list " + dir.string() + ": " + ec.message());
    require(!frames.empty(), ErrorCode::Io, "sequence: no frame (NNNNNNNNNN.png) in " + dir.string());
    std::sort(frames.begin(), frames.end());
    return frames;
}

// KITTI raw keeps the calibration in the date folder, one above the drive.
std::string find_calibration(const fs::path &root, const char *name) {
    for (const fs::path &p : {root / name, root.parent_path() / name}) {
        std::error_code ec;
        if (fs::is_regular_file(p, ec)) return p.string();
    }
    throw Error(ErrorCode::Io, std::string("sequence: no ") + name + " in " + root.string() + " or " +
                                   root.parent_path().string());
}

// Times of image_02/timestamps.txt ("YYYY-MM-DD HH:MM:SS.fffffffff", line k = frame k) in
// seconds; empty when the file is absent or a line does not parse (they only annotate output).
std::vector<double> read_timestamps(const fs::path &root) {
    std::ifstream in(root / "image_02" / "timestamps.txt");
    std::vector<double> t;
    std::string line;
    while (std::getline(in, line)) {
        std::tm tm{};
        double sec = 0;
        if (std::sscanf(line.c_str(), "%d-%d-%d %d:%d:%lf", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour,
                        &tm.tm_min, &sec) != 6)
            return {};
        tm.tm_year -= 1900;
        tm.tm_mon -= 1;
        tm.tm_sec = 0;
        t.push_back(static_cast<double>(timegm(&tm)) + sec);
    }
    return t;
}

struct Frame {
    long index = 0;
    cv::Mat left, right;
    SparseLidar lidar;
};

// A bad frame: which of its files and why.
struct FrameError {
    std::string file;  // relative to the drive
    std::string reason;
};

// The reason of an error about `path`, without the path when the message starts with it.
std::string reason_of(const Error &e, const std::string &path) {
    std::string m = e.what();
    if (m.compare(0, path.size() + 2, path + ": ") == 0) m = m.substr(path.size() + 2);
    return m;
}

class DriveReader {
public:
    DriveReader(fs::path root, const io::CamToCamCalib &calib, const cv::Matx44d &velo_to_left)
        : root_(std::move(root)), camera_(calib.camera), velo_to_left_(velo_to_left) {}

    // Frame k, or the error of its first bad file. `size`: the size every frame must have
    // (empty: this frame's sets it).
    std::optional<Frame> read(long k, cv::Size &size, FrameError &error) const {
        const std::string name = frame_name(k);
        Frame f;
        f.index = k;
        std::string rel;
        try {
            rel = "image_02/data/" + name + ".png";
            f.left = read_image(rel);
            if (size.empty()) size = f.left.size();
            check_size(f.left, size);
            rel = "image_03/data/" + name + ".png";
            f.right = read_image(rel);
            check_size(f.right, size);
            if (f.right.type() != f.left.type())
                throw Error(ErrorCode::Format, "is " + channels_text(f.right) + " but the left image is " +
                                                   channels_text(f.left));
            rel = "velodyne_points/data/" + name + ".bin";
            const std::string path = (root_ / rel).string();
            if (!fs::exists(path)) throw Error(ErrorCode::Io, "missing");
            const io::VelodyneScan scan = io::read_velodyne_bin(path);
            std::vector<cv::Point3f> points(scan.points.size());
            for (size_t i = 0; i < points.size(); ++i)
                points[i] = {scan.points[i].x, scan.points[i].y, scan.points[i].z};
            // The C ABI's LF_LIDAR_POINTS_LIDAR path, so that results equal pushed frames'.
            f.lidar = lidar::project_to_left_camera(points, &velo_to_left_, camera_, size);
            detail("sequence: frame %s: scan of %zu points, %zu in the image\n", name.c_str(), scan.points.size(),
                   f.lidar.points.size());
        } catch (const Error &e) {
            error = {rel, reason_of(e, (root_ / rel).string())};
            return std::nullopt;
        }
        return f;
    }

private:
    cv::Mat read_image(const std::string &rel) const {
        const std::string path = (root_ / rel).string();
        if (!fs::exists(path)) throw Error(ErrorCode::Io, "missing");
        return io::read_any_image(path);
    }
    static std::string channels_text(const cv::Mat &m) { return m.channels() == 1 ? "gray" : "colour"; }
    static void check_size(const cv::Mat &m, cv::Size size) {
        if (m.size() != size)
            throw Error(ErrorCode::SizeMismatch, "is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) +
                                                     ", the drive's frames are " + std::to_string(size.width) + "x" +
                                                     std::to_string(size.height));
    }

    fs::path root_;
    StereoCamera camera_;
    cv::Matx44d velo_to_left_;
};

// "A:B" with 0 <= A < B.
std::pair<long, long> parse_range(const std::string &text) {
    const size_t colon = text.find(':');
    auto number = [&](const std::string &s) {
        require(!s.empty() && s.size() <= 10 && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); }),
                ErrorCode::InvalidArgument, "sequence: --frames must be A:B with frame numbers A < B, got '" + text + "'");
        return std::stol(s);
    };
    require(colon != std::string::npos, ErrorCode::InvalidArgument,
            "sequence: --frames must be A:B with frame numbers A < B, got '" + text + "'");
    const long a = number(text.substr(0, colon)), b = number(text.substr(colon + 1));
    require(a < b, ErrorCode::InvalidArgument, "sequence: --frames " + text + " holds no pair (needs A < B)");
    // Every index of the range is visited (a missing one is reported): bounded, not 10^10 lines.
    require(b - a <= kMaxPairs, ErrorCode::InvalidArgument,
            "sequence: --frames " + text + " spans more than " + std::to_string(kMaxPairs) + " pairs");
    return {a, b};
}

std::string pair_text(long t0) { return std::to_string(t0) + "->" + std::to_string(t0 + 1); }

int run_sequence(int argc, char **argv) {
    Args args("sequence", argc, argv,
              {{"drive", true, "DIR  drive in the KITTI raw layout: image_02/data/NNNNNNNNNN.png, image_03/data, velodyne_points/data/NNNNNNNNNN.bin; calib_cam_to_cam.txt and calib_velo_to_cam.txt in DIR or DIR/.."},
               {"out", true, "DIR  output folder: disp_0/, disp_1/, flow/, one file each per pair, named by its first frame (NNNNNNNNNN.EXT)"},
               {"frames", true, "A:B  frames A..B (inclusive): pairs A->A+1 .. B-1->B, at most 1000000 (default: every frame)"},
               {"format", true, "F,.. result files: kitti (16-bit PNG, default) | flo | pfm | npy"},
               {"preset", true, "NAME speed/accuracy preset: default | paper | balanced | fast | realtime"},
               {"option", true, "K=V  any option key of the C ABI (lidarflow.h), after the preset; repeatable, or K=V,K=V"},
               {"set", true, "K=V,.. the same as --option (as `run` and `kitti` name it)"},
               {"threads", true, "N    OpenMP threads (default: every usable CPU, fewer while others are busy)"},
               {"skip-existing", false, "do not recompute a pair whose result files all exist (counted as skipped)"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        std::printf("exit status: 0 every pair done; 3 some pairs skipped for bad frames (each reported on stderr);\n"
                    "             1 other errors (unreadable drive, no calibration); 2 bad command line\n");
        return 0;
    }
    const fs::path root = fs::path(args.required("drive")).lexically_normal();
    const std::string out = args.required("out");
    const std::vector<io::ResultFormat> formats =
        parse_formats(args.has("format") ? args.list("format") : std::vector<std::string>{"kitti"}, "sequence");
    pipeline::EstimatorOptions opt = pipeline::EstimatorOptions::preset(args.str("preset", "default"));
    opt.threads = args.integer("threads", opt.threads);
    std::vector<std::string> assignments;
    std::vector<std::string> given = args.all("option");
    for (const std::string &a : args.all("set")) given.push_back(a);
    for (const std::string &a : given)
        for (const std::string &item : split_list(a)) assignments.push_back(item);
    pipeline::apply_option_assignments(opt, assignments);
    opt.keep_stage_fields = false;  // only the output is written, as the C ABI keeps only it
    const pipeline::Estimator estimator(opt);  // checks the options before any file is read
    const bool skip_existing = args.flag("skip-existing");

    const std::vector<long> listed = list_frames(root);
    const io::CamToCamCalib calib = io::read_calib_cam_to_cam(find_calibration(root, "calib_cam_to_cam.txt"));
    const cv::Matx44d velo_to_left =
        io::velo_to_left_rect(calib, io::read_calib_velo_to_cam(find_calibration(root, "calib_velo_to_cam.txt")));
    const std::vector<double> stamps = read_timestamps(root);
    long first = listed.front(), last = listed.back();
    if (args.has("frames")) std::tie(first, last) = parse_range(args.str("frames", ""));
    require(first < last, ErrorCode::Io, "sequence: " + root.string() + " has one frame only: no pair");
    require(last - first <= kMaxPairs, ErrorCode::Io,
            "sequence: " + root.string() + " spans frames " + std::to_string(first) + ".." + std::to_string(last) +
                ", more than " + std::to_string(kMaxPairs) + " pairs (choose a part with --frames A:B)");
    io::prepare_output_folder(out);
    const std::set<long> present(listed.begin(), listed.end());
    detail("sequence: %s: frames %ld..%ld (%zu listed in the drive), preset %s, %d thread(s), fx %.2f px, baseline "
           "%.4f m\n",
           root.c_str(), first, last, listed.size(), args.str("preset", "default").c_str(), opt.threads,
           calib.camera.fx, calib.camera.baseline);

    const DriveReader reader(root, calib, velo_to_left);
    const bool tty = isatty(fileno(stderr)) && verbosity() != Verbosity::Quiet;
    const long pairs = last - first;
    long computed = 0, skipped = 0, done = 0;
    std::set<long> failed;  // pairs (by their t0) lost to bad frames or estimator errors
    quality::Tally quality;
    const Stopwatch clock;
    const auto progress = [&](long t0, const std::string &what) {
        ++done;
        const double now = clock.seconds();
        const std::string eta =
            format_duration(now / static_cast<double>(done) * static_cast<double>(pairs - done));
        // As `kitti`: on a terminal one line rewritten in place, piped one line per pair.
        note(tty ? "\r\033[K[%ld/%ld] %s %s  (elapsed %s, ETA %s)" : "[%ld/%ld] %s %s  (elapsed %s, ETA %s)\n", done,
             pairs, pair_text(t0).c_str(), what.c_str(), format_duration(now).c_str(), eta.c_str());
    };
    const auto lose = [&](long t0, const std::string &why) {
        if (!failed.insert(t0).second) return;
        progress(t0, why);
    };

    std::optional<Frame> prev;
    pipeline::StreamCache stream;
    cv::Size size;
    for (long k = first; k <= last; ++k) {
        std::optional<Frame> cur;
        FrameError bad;
        if (present.count(k)) {
            cur = reader.read(k, size, bad);
        } else {
            bad = {"image_02/data/" + frame_name(k) + ".png", "missing"};
        }
        if (!cur) {
            std::vector<long> lost;
            if (k > first && !failed.count(k - 1)) lost.push_back(k - 1);
            if (k < last) lost.push_back(k);
            std::string list;
            for (long t0 : lost) list += (list.empty() ? "" : ", ") + pair_text(t0);
            if (tty) std::fprintf(stderr, "\r\033[K");
            std::fprintf(stderr, "sequence: frame %s: %s: %s%s\n", frame_name(k).c_str(), bad.file.c_str(),
                         bad.reason.c_str(),
                         list.empty() ? "" : ("; pair" + std::string(lost.size() > 1 ? "s " : " ") + list + " skipped").c_str());
            for (long t0 : lost) lose(t0, "skipped (bad frame)");
            // The stream restarts after a bad frame: no pair spans it.
            prev.reset();
            stream.clear();
            continue;
        }
        if (prev) {
            const long t0 = prev->index;
            const std::string id = frame_name(t0);
            bool exists = skip_existing;
            if (skip_existing)
                for (const std::string &p : result_file_paths(out, id, formats)) exists = exists && fs::exists(p);
            if (exists) {
                ++skipped;
                progress(t0, "exists, skipped");
            } else {
                pipeline::FrameInput in;
                in.left0 = prev->left;
                in.right0 = prev->right;
                in.left1 = cur->left;
                in.right1 = cur->right;
                in.lidar0 = prev->lidar;
                in.lidar1 = cur->lidar;
                in.camera = calib.camera;
                const Stopwatch pair_clock;
                std::optional<pipeline::EstimatorResult> r;
                try {
                    r = estimator.run(in, &stream);
                } catch (const Error &e) {
                    if (tty) std::fprintf(stderr, "\r\033[K");
                    std::fprintf(stderr, "sequence: pair %s: %s\n", pair_text(t0).c_str(), e.what());
                    stream.clear();
                    lose(t0, "failed");
                }
                if (r) {
                    write_result_files(out, id, r->output(), formats);
                    const double s = pair_clock.seconds();
                    ++computed;
                    quality.add(r->quality.flags);
                    std::string what = "in " + format_duration(s);
                    if (!r->quality.ok()) what += ", quality: " + r->quality.summary();
                    if (static_cast<size_t>(k) < stamps.size()) {
                        char dt[48];
                        std::snprintf(dt, sizeof dt, ", frames %.3f s apart",
                                      stamps[static_cast<size_t>(k)] - stamps[static_cast<size_t>(t0)]);
                        what += dt;
                    }
                    progress(t0, what);
                }
            }
        }
        prev = std::move(cur);
    }
    if (tty) std::fprintf(stderr, "\r\033[K");
    const double total = clock.seconds();
    std::printf("sequence: %ld pairs: %ld computed, %ld skipped (existing), %zu failed (bad frames); %.2f pairs/s "
                "(%ld computed in %s)\n",
                pairs, computed, skipped, failed.size(), total > 0 ? computed / total : 0.0, computed,
                format_duration(total).c_str());
    std::printf("sequence: quality: %s\n", quality.text().c_str());
    return failed.empty() ? 0 : kExitBadFrames;
}

}  // namespace

LIDARFLOW_COMMAND(sequence, "sequence", "scene flow for every consecutive pair of a recorded drive (KITTI raw layout)",
                  run_sequence, 57);

}  // namespace lidarflow::cli
