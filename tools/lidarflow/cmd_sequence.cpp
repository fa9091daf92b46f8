// SPDX-License-Identifier: MIT
// lidarflow sequence: scene flow for every consecutive frame pair of a recorded drive in the
// KITTI raw layout (io/drive_folder.hpp), streamed through one estimator as the C ABI streams
// pushed frames, so each frame's work is reused by the next pair. Bad frames and misnamed files
// are reported and only their pairs are skipped. The rig is the drive's calibration files or
// `run`'s rig options (rig_args.hpp); a raw rig's pairs are rectified as they are read.
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "ego_matrix.hpp"
#include "log.hpp"
#include "result_files.hpp"
#include "result_manifest.hpp"
#include "rig_args.hpp"
#include "sequence_poses.hpp"
#include "core/error.hpp"
#include "core/error_of.hpp"
#include "core/log.hpp"
#include "core/ordered_pool.hpp"
#include "io/calib.hpp"
#include "io/drive_folder.hpp"
#include "io/output_folder.hpp"
#include "io/rectify.hpp"
#include "io/velo_to_left.hpp"
#include "lidar/projection.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/option_assignments.hpp"
#include "pipeline/option_keys.hpp"

namespace lidarflow::cli {
namespace {

namespace fs = std::filesystem;

constexpr int kExitBadFrames = 3;  // as the bridge's --replay for lost frames
constexpr long kMaxPairs = 1000000;  // 28 hours at 10 Hz

// KITTI raw keeps the calibration in the date folder, one above the drive.
std::string find_calibration(const fs::path &root, const char *name) {
    for (const fs::path &p : {root / name, root.parent_path() / name}) {
        std::error_code ec;
        if (fs::symlink_status(p, ec).type() != fs::file_type::not_found && !ec) return p.string();
    }
    throw Error(ErrorCode::Io, std::string("sequence: no ") + name + " in " + root.string() + " or " +
                                   root.parent_path().string());
}

struct Frame {
    long index = 0;
    cv::Mat left, right;
    SparseLidar lidar;
    io::DriveFileError scan_error;  // set: the scan is bad, the frame goes image-only (no points)
};

// Frame k through io::read_drive_frame, rectified when `rectifier` is given, its scan projected
// as the C ABI's LF_LIDAR_POINTS_LIDAR path projects pushed scans, so that results equal pushed
// frames'.
std::optional<Frame> read_frame(const fs::path &root, long k, cv::Size size, const StereoCamera &camera,
                                const cv::Matx44d &velo_to_left, const io::Rectifier *rectifier,
                                io::DriveFileError &error) {
    io::DriveFrame d;
    if (!io::read_drive_frame(root.string(), k, size, d, error)) return std::nullopt;
    if (rectifier) rectifier->apply(d.left, d.right, d.left, d.right);
    std::vector<cv::Point3f> points(d.scan.points.size());
    for (size_t i = 0; i < points.size(); ++i) points[i] = {d.scan.points[i].x, d.scan.points[i].y, d.scan.points[i].z};
    Frame f;
    f.index = k;
    f.left = std::move(d.left);
    f.right = std::move(d.right);
    f.scan_error = std::move(d.scan_error);
    // Without points the pair is image-only, as a frame pushed without LiDAR through the C ABI.
    f.lidar = f.scan_error.file.empty() ? lidar::project_to_left_camera(points, &velo_to_left, camera, size)
                                        : SparseLidar{size.width, size.height, {}};
    detail("sequence: frame %s: scan of %zu points, %zu in the image\n", io::drive_frame_name(k).c_str(),
           d.scan.points.size(), f.lidar.points.size());
    return f;
}

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

// "sequence: frame N: FILE: REASON; pairs A->B, B->C WHAT" on stderr (on a terminal, over the
// progress line).
void report_frame(bool tty, long k, const io::DriveFileError &e, const std::vector<long> &pairs, const char *what) {
    std::string list;
    for (long t0 : pairs) list += (list.empty() ? "" : ", ") + pair_text(t0);
    if (!list.empty()) list = "; pair" + std::string(pairs.size() > 1 ? "s " : " ") + list + " " + what;
    if (tty) std::fprintf(stderr, "\r\033[K");
    std::fprintf(stderr, "sequence: frame %s: %s: %s%s\n", io::drive_frame_name(k).c_str(), e.file.c_str(),
                 e.reason.c_str(), list.c_str());
}

// A pair's metric ego-motion [R | t] (points of the t0 camera -> the t1 camera), if it has one.
std::optional<cv::Matx34d> metric_ego(const pipeline::EstimatorResult &r) {
    if (r.ego_state != pipeline::EgoState::Ok) return std::nullopt;
    return ego_matrix(r.ego).get_minor<3, 4>(0, 0);
}

// The rig and LiDAR transform when they are not the drive's own files, for the manifests:
// results of another calibration are recomputed, not skipped.
std::string rig_settings_text(const io::Rig &rig, const cv::Matx44d &velo_to_left) {
    std::string s;
    const auto add = [&s](const char *name, const double *v, int n) {
        s += name;
        char number[32];
        for (int i = 0; i < n; ++i) {
            std::snprintf(number, sizeof number, " %.17g", v[i]);
            s += number;
        }
        s += "\n";
    };
    const StereoCamera &c = rig.rect.camera;
    const double camera[5] = {c.fx, c.fy, c.cx, c.cy, c.baseline};
    add("rig.camera=", camera, 5);
    if (rig.rectify)
        for (const io::RawCamera *cam : {&rig.left, &rig.right}) {
            add("rig.raw.K=", cam->K.val, 9);
            add("rig.raw.D=", cam->D.val, 8);
            add("rig.raw.R=", cam->R.val, 9);
            add("rig.raw.P=", cam->P.val, 12);
        }
    add("rig.velo_to_left=", velo_to_left.val, 16);
    return s;
}

std::vector<OptionSpec> sequence_options() {
    std::vector<OptionSpec> spec = {
        {"drive", true, "DIR  drive in the KITTI raw layout: image_02/data/NNNNNNNNNN.png, image_03/data, velodyne_points/data/NNNNNNNNNN.bin; calib_cam_to_cam.txt (unless --calib or --fx ...) and calib_velo_to_cam.txt (unless --calib-velo) in DIR or DIR/.."}};
    for (OptionSpec &o : rig_option_specs()) spec.push_back(o);
    spec.push_back({"calib-velo", true,
                    "FILE Velodyne -> left camera in calib_velo_to_cam.txt's form (R:, T:), into the camera the rig's "
                    "left rectifying rotation starts from (KITTI: camera 0; default: the drive's file)"});
    return spec;
}

int run_sequence(int argc, char **argv) {
    std::vector<OptionSpec> spec = sequence_options();
    spec.insert(spec.end(),
              {{"out", true, "DIR  output folder: disp_0/, disp_1/, flow/, one file each per pair, named by its first frame (NNNNNNNNNN.EXT), and manifest/NNNNNNNNNN.txt"},
               {"frames", true, "A:B  frames A..B (inclusive): pairs A->A+1 .. B-1->B, at most 1000000 (default: every frame)"},
               {"format", true, "F,.. result files: kitti (16-bit PNG, default) | flo | pfm | npy"},
               {"preset", true, "NAME speed/accuracy preset: default | paper | balanced | fast | realtime"},
               {"option", true, "K=V  any option key of the C ABI (lidarflow.h), after the preset; repeatable, or K=V,K=V"},
               {"set", true, "K=V,.. the same as --option (as `run` and `kitti` name it)"},
               {"threads", true, "N    OpenMP threads (default: every usable CPU, fewer while others are busy)"},
               {"frames-in-flight", true, "N    pairs computed at once, each on threads / N threads (at least 1), written in order; the motion prior comes from the pair N before, nothing else of the stream is reused (default 1: one stream)"},
               {"poses", true, "F    camera trajectory: kitti (default; OUT/poses.txt, KITTI odometry: frame A the origin) | tum | none"},
               {"warm-up", true, "N    with --frames A:B, start the stream N frames before A: pairs before A are computed for the stream's priors, not written (default 0)"},
               {"skip-existing", false, "do not recompute a pair whose manifest vouches for its files with these settings (counted as skipped)"}});
    Args args("sequence", argc, argv, spec);
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        std::printf("exit status: 0 every pair done; 3 some input bad: pairs skipped for bad images (or an error\n"
                    "             of the estimator on the pair, out of memory included), image-only for bad scans,\n"
                    "             or misnamed files\n"
                    "             (each reported on stderr); 1 other errors (unreadable drive, bad calibration,\n"
                    "             an output that cannot be written); 2 bad command line\n");
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
    // The option key's own checks and message.
    if (args.has("frames-in-flight"))
        assignments.push_back("frames_in_flight=" + std::to_string(args.integer("frames-in-flight", 1)));
    pipeline::apply_option_assignments(opt, assignments);
    opt.keep_stage_fields = false;  // only the output is written, as the C ABI keeps only it
    pipeline::EstimatorOptions per_pair = opt;
    per_pair.threads = opt.per_frame_threads();
    const pipeline::Estimator estimator(per_pair);  // checks the options before any file is read
    const bool skip_existing = args.flag("skip-existing");
    const long warm_up = args.integer("warm-up", 0);
    require(warm_up >= 0 && warm_up <= 1000, ErrorCode::InvalidArgument,
            "sequence: --warm-up must be in [0, 1000] frames, got " + std::to_string(warm_up));
    const std::string poses_name = args.str("poses", "kitti");
    const bool write_poses = poses_name != "none";
    const io::PoseFormat poses_format = write_poses ? io::parse_pose_format(poses_name) : io::PoseFormat::Kitti;
    // --calib / --fx ... and --calib-velo stand in for the drive's files, each for its own.
    const std::optional<io::Rig> given_rig = rig_from_args(args, "sequence");
    std::string settings_text = pipeline::result_settings_text(opt);
    const io::DriveListing listing = io::list_drive(root.string());
    require(!listing.frames.empty(), ErrorCode::Io,
            "sequence: no frame (NNNNNNNNNN.png / .bin) in the data folders of " + root.string());
    const io::Rig rig = given_rig ? *given_rig
                                  : io::rig_from_kitti(io::read_calib_cam_to_cam(
                                        find_calibration(root, "calib_cam_to_cam.txt")));
    const io::CamToCamCalib &calib = rig.rect;
    const cv::Matx44d velo_to_left = io::velo_to_left_rect(
        calib, io::read_calib_velo_to_cam(args.has("calib-velo") ? args.str("calib-velo", "")
                                                                  : find_calibration(root, "calib_velo_to_cam.txt")));
    if (given_rig || args.has("calib-velo")) settings_text += rig_settings_text(rig, velo_to_left);
    // Image-only results are of other inputs: a rerun with the scan readable recomputes them.
    const uint64_t settings = settings_digest(settings_text),
                   image_only_settings = settings_digest(settings_text + "lidar=none\n");
    const io::DriveTimestamps stamps = io::read_drive_timestamps(root.string());
    long first = listing.frames.front(), last = listing.frames.back();
    if (args.has("frames")) std::tie(first, last) = parse_range(args.str("frames", ""));
    require(first < last, ErrorCode::Io, "sequence: " + root.string() + " has one frame only: no pair");
    require(last - first <= kMaxPairs, ErrorCode::Io,
            "sequence: " + root.string() + " spans frames " + std::to_string(first) + ".." + std::to_string(last) +
                ", more than " + std::to_string(kMaxPairs) + " pairs (choose a part with --frames A:B)");
    inputs_begin();
    io::prepare_output_folder(out);
    const std::set<long> present(listing.frames.begin(), listing.frames.end());
    std::vector<long> in_range;
    for (long k : listing.frames)
        if (k >= first && k <= last) in_range.push_back(k);
    const cv::Size size = io::drive_frame_size(root.string(), in_range);
    std::optional<io::Rectifier> rectifier;  // a raw rig's tables, made once for the drive
    if (!size.empty()) {  // empty: no frame is readable, each is reported as bad
        check_image_size(rig, size, args.flag("strict"), "sequence");
        if (rig.rectify) {
            rectifier.emplace(rig, size);
            note("sequence: raw images: each pair is rectified, results are in the rectified left camera (fx %.2f px, "
                 "baseline %.4f m)\n",
                 calib.camera.fx, calib.camera.baseline);
        }
    }
    const io::Rectifier *const rectify = rectifier ? &*rectifier : nullptr;
    detail("sequence: %s: frames %ld..%ld (%zu listed in the drive), %dx%d, preset %s, %d thread(s), fx %.2f px, "
           "baseline %.4f m\n",
           root.c_str(), first, last, listing.frames.size(), size.width, size.height,
           args.str("preset", "default").c_str(), opt.threads, calib.camera.fx, calib.camera.baseline);

    // Input that is bad but costs no pair is reported too, and makes the exit status 3.
    long misnamed = 0;
    for (const io::MisnamedFile &m : listing.misnamed) {
        if (m.number >= 0 && (m.number < first || m.number > last)) continue;
        ++misnamed;
        std::fprintf(stderr, "sequence: %s: not a frame's name (10 digits and the folder's extension); ignored\n",
                     m.file.c_str());
    }
    if (!stamps.problem.empty())
        std::fprintf(stderr, "sequence: image_02/timestamps.txt: %s; progress lines without frame times\n",
                     stamps.problem.c_str());

    const bool tty = isatty(fileno(stderr)) && verbosity() != Verbosity::Quiet;
    const long pairs = last - first;
    long computed = 0, computed_image_only = 0, skipped = 0, done = 0;
    std::set<long> failed;      // pairs (by their t0) lost to bad frames or estimator errors
    std::set<long> image_only;  // pairs computed without points for a bad scan
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

    std::map<long, cv::Matx34d> motions;  // pair t0 -> its metric ego-motion [R | t]
    std::optional<Frame> prev;
    pipeline::StreamCache stream;
    // What a pair writes once it is computed (now, or in its turn with frames in flight).
    struct Pair {
        long t0 = 0, k = 0;  // its frames
        std::string id;
        std::vector<std::string> files;
        bool no_points = false;
        uint64_t settings = 0;
        bool warm_up = false;  // computed for the priors only, not written
    };
    struct Computed {
        pipeline::EstimatorResult r;
        double seconds = 0;
        std::shared_ptr<const matching::DecoupledStereo> prior;  // frames in flight: for the pair N later
    };
    const auto finish = [&](const Pair &p, const std::function<Computed()> &compute) {
        std::optional<Computed> c;
        try {
            c = compute();
        } catch (...) {  // a bad pair, OpenCV or memory: reported, and the drive goes on (exit 3)
            const Error e = error_of_current_exception("sequence: pair " + pair_text(p.t0));
            if (tty) std::fprintf(stderr, "\r\033[K");
            std::fprintf(stderr, "%s\n", e.what());
            stream.clear();
            lose(p.t0, "failed");
        }
        if (!c) return;
        const pipeline::EstimatorResult &r = c->r;
        const std::optional<cv::Matx34d> ego = metric_ego(r);
        if (ego) motions[p.t0] = *ego;
        write_result_files(out, p.id, r.output(), formats);
        write_result_manifest(out, p.id, p.settings, p.files, ego);
        ++computed;
        computed_image_only += p.no_points ? 1 : 0;
        quality.add(r.quality.flags);
        std::string what = (p.no_points ? "image-only in " : "in ") + format_duration(c->seconds);
        if (!r.quality.ok()) what += ", quality: " + r.quality.summary();
        if (static_cast<size_t>(p.k) < stamps.seconds.size()) {
            char dt[48];
            std::snprintf(dt, sizeof dt, ", frames %.3f s apart",
                          stamps.seconds[static_cast<size_t>(p.k)] - stamps.seconds[static_cast<size_t>(p.t0)]);
            what += dt;
        }
        progress(p.t0, what);
    };
    // Warm-up: the frames before the range feed the stream only (a part of a drive then gets the
    // priors a whole run would have had); their problems are not the range's.
    // The frame times, where the drive has them: a pair's time step lets the stream drop priors
    // across a dropped frame, as the C ABI's timestamps do.
    const auto time_of = [&](long k) -> std::optional<double> {
        if (k < 0 || static_cast<size_t>(k) >= stamps.seconds.size()) return std::nullopt;
        return stamps.seconds[static_cast<size_t>(k)];
    };
    const auto pair_input = [&](const Frame &a, const Frame &b) {
        pipeline::FrameInput in{a.left, a.right, b.left, b.right, a.lidar, b.lidar, calib.camera, calib.image_size};
        const std::optional<double> ta = time_of(a.index), tb = time_of(b.index);
        if (ta && tb && *tb > *ta) in.step_us = static_cast<int64_t>(std::llround((*tb - *ta) * 1e6));
        return in;
    };
    // Frames in flight: pair k runs beside pairs k-N+1 .. k-1, with the motion prior of pair
    // k-N (finished by then) as the C ABI's handle does; written in their turn.
    const int lag = opt.frames_in_flight;
    const std::unique_ptr<OrderedPool<Computed>> pool =
        lag > 1 ? std::make_unique<OrderedPool<Computed>>(lag) : nullptr;
    std::deque<Pair> in_flight;
    long no_prior_before = 0;  // the frame after the last bad one
    std::shared_ptr<const matching::DecoupledStereo> prior;  // of the pair written last
    long prior_t0 = -1;                                    // its first frame (-1: none)
    const auto finish_oldest = [&] {
        std::future<Computed> f = pool->take_oldest();
        const Pair p = in_flight.front();
        in_flight.pop_front();
        prior.reset();
        prior_t0 = -1;
        if (p.warm_up) {
            try {
                prior = f.get().prior;
                prior_t0 = p.t0;
            } catch (...) {  // a warm-up pair only feeds the priors: none from it
            }
            return;
        }
        finish(p, [&] {
            Computed c = f.get();
            prior = c.prior;
            prior_t0 = p.t0;
            return c;
        });
    };
    const auto submit = [&](const Frame &a, const Frame &b, const Pair &pair) {
        // A bad frame restarts the stream: no prior across it.
        std::shared_ptr<const matching::DecoupledStereo> lagged =
            prior_t0 == pair.t0 - lag && prior_t0 >= no_prior_before ? prior : nullptr;
        const std::optional<double> p0 = time_of(prior_t0), p1 = time_of(prior_t0 + 1), t0 = time_of(pair.t0);
        const std::string context = "pair " + pair_text(pair.t0);
        if (lagged && p0 && p1 && t0 && !pipeline::lagged_prior_in_pace(*p0, *p1, *t0, lag)) {
            const log::Scope scope(context);
            log::write(log::Level::Info, "no motion prior for this pair: the frames since the pair that made it "
                                         "are not evenly spaced (a dropped frame?)");
            lagged = nullptr;
        }
        pool->submit([&estimator, &pair_input, a, b, lag, lagged, context] {
            const log::Scope scope(context);  // its messages name it: pairs in flight interleave
            const Stopwatch clock;
            pipeline::StreamCache cache;
            cache.set_in_flight(lag, lagged);
            Computed c{estimator.run(pair_input(a, b), &cache), 0, nullptr};
            c.seconds = clock.seconds();
            c.prior = cache.prior_for_later();
            return c;
        });
        in_flight.push_back(pair);
        if (pool->full()) finish_oldest();
    };
    const auto warm_pair = [&](const Frame &a, const Frame &b) {
        if (pool) {
            Pair warm;
            warm.t0 = a.index;
            warm.k = b.index;
            warm.warm_up = true;
            submit(a, b, warm);
            return;
        }
        try {
            estimator.run(pair_input(a, b), &stream);
        } catch (...) {  // as above
            stream.clear();
        }
    };
    for (long k = std::max(listing.frames.front(), first - warm_up); k < first; ++k) {
        io::DriveFileError ignored;
        std::optional<Frame> cur;
        if (present.count(k)) cur = read_frame(root, k, size, calib.camera, velo_to_left, rectify, ignored);
        if (cur && prev) warm_pair(*prev, *cur);
        if (!cur) {
            stream.clear();
            no_prior_before = k + 1;
        }
        prev = std::move(cur);
    }
    for (long k = first; k <= last; ++k) {
        std::optional<Frame> cur;
        io::DriveFileError bad;
        if (present.count(k)) {
            cur = read_frame(root, k, size, calib.camera, velo_to_left, rectify, bad);
        } else {
            bad = {io::drive_left_file(k), "missing"};
        }
        if (!cur) {
            std::vector<long> lost;
            if (k > first && !failed.count(k - 1)) lost.push_back(k - 1);
            if (k < last) lost.push_back(k);
            report_frame(tty, k, bad, lost, "skipped");
            for (long t0 : lost) lose(t0, "skipped (bad frame)");
            // The stream restarts after a bad frame: no pair spans it, no prior crosses it.
            prev.reset();
            stream.clear();
            no_prior_before = k + 1;
            continue;
        }
        if (!cur->scan_error.file.empty()) {
            std::vector<long> pairs_of;
            if (prev && k > first) pairs_of.push_back(k - 1);
            if (k < last) pairs_of.push_back(k);
            report_frame(tty, k, cur->scan_error, pairs_of, "image-only");
        }
        if (prev && prev->index < first) {
            warm_pair(*prev, *cur);  // the last warm-up pair
        } else if (prev) {
            const long t0 = prev->index;
            const std::string id = io::drive_frame_name(t0);
            const std::vector<std::string> files = result_file_paths(out, id, formats);
            const bool no_points = !prev->scan_error.file.empty() || !cur->scan_error.file.empty();
            if (no_points) image_only.insert(t0);
            const uint64_t pair_settings = no_points ? image_only_settings : settings;
            std::optional<cv::Matx34d> ego;
            const Pair pair{t0, k, id, files, no_points, pair_settings, false};
            if (skip_existing && result_manifest_matches(out, id, pair_settings, files, ego)) {
                if (ego) motions[t0] = *ego;
                ++skipped;
                progress(t0, "exists, skipped");
            } else if (pool) {
                submit(*prev, *cur, pair);
            } else {
                finish(pair, [&] {
                    const Stopwatch clock;
                    Computed c{estimator.run(pair_input(*prev, *cur), &stream), 0, nullptr};
                    c.seconds = clock.seconds();
                    return c;
                });
            }
        }
        prev = std::move(cur);
    }
    while (pool && pool->in_flight() > 0) finish_oldest();
    if (tty) std::fprintf(stderr, "\r\033[K");
    if (write_poses) {
        // A part of a drive (--frames) gets a file of its own: parts may share OUT.
        const std::string file = args.has("frames") ? "poses_" + io::drive_frame_name(first) + "-" +
                                                          io::drive_frame_name(last) + ".txt"
                                                    : "poses.txt";
        const long reached = write_sequence_poses((fs::path(out) / file).string(), first, motions, stamps.seconds,
                                                  poses_format);
        if (reached < last)
            std::fprintf(stderr, "sequence: %s: frames %ld..%ld only (pair %s has no ego-motion)\n", file.c_str(), first,
                         reached, pair_text(reached).c_str());
    }
    const double total = clock.seconds();
    std::printf("sequence: %ld pairs: %ld computed%s, %ld skipped (existing), %zu failed (bad frames)%s; %.2f pairs/s "
                "(%ld computed in %s)\n",
                pairs, computed,
                computed_image_only ? (" (" + std::to_string(computed_image_only) + " image-only)").c_str() : "", skipped,
                failed.size(),
                misnamed ? ("; " + std::to_string(misnamed) + " misnamed file(s) ignored").c_str() : "",
                total > 0 ? computed / total : 0.0, computed, format_duration(total).c_str());
    std::printf("sequence: quality: %s\n", quality.text().c_str());
    return failed.empty() && image_only.empty() && misnamed == 0 ? 0 : kExitBadFrames;
}

}  // namespace

LIDARFLOW_COMMAND(sequence, "sequence", "scene flow for every consecutive pair of a recorded drive (KITTI raw layout; your rig: --calib)",
                  run_sequence, 57);

}  // namespace lidarflow::cli
