// SPDX-License-Identifier: MIT
// Property test of the drive folder reader (io/drive_folder.hpp) that `lidarflow sequence` uses:
// random drives (fixed seeds) whose frame files are of random kinds (valid, another size, gray
// or colour, absent, FIFO, folder, symlink loop, dangling symlink, /dev/zero, empty, garbage, a
// 100 GiB sparse scan) next to misnamed and foreign names. For every drive:
//  - list_drive lists exactly the indices with an entry named as a frame in any data folder, and
//    exactly the misnamed names, never opening an entry;
//  - drive_frame_size is the most common size of the valid left images (ties: the earliest);
//  - read_drive_frame succeeds exactly for frames whose two images are valid, of that size and
//    of one type, and otherwise names the first bad image (left, right) with the reason its
//    kind gives (a bad scan leaves the frame good, without points, its error apart), without
//    blocking (an alarm ends a hung run) or throwing.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "io/drive_folder.hpp"
// cmocka 1.1.5's header lacks extern "C" and its fail() macro breaks <ios>: include it last.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;
namespace fs = std::filesystem;

namespace {

enum class Kind { Valid, OtherSize, Colour, Absent, Fifo, Folder, Loop, Dangling, DevZero, Empty, Garbage, Huge };

const cv::Size kSizes[2] = {{8, 6}, {10, 6}};

struct FileSpec {
    Kind kind = Kind::Absent;
    int size = 0;  // index into kSizes, for images
};

struct FrameSpec {
    FileSpec left, right, scan;
};

void write_bytes(const fs::path &p, const std::string &bytes) { std::ofstream(p, std::ios::binary) << bytes; }

void make_file(const fs::path &p, const FileSpec &f, bool image) {
    switch (f.kind) {
    case Kind::Valid:
    case Kind::OtherSize:
    case Kind::Colour:
        if (image) {
            const cv::Mat m = f.kind == Kind::Colour ? cv::Mat(kSizes[f.size], CV_8UC3, cv::Scalar(40, 90, 200))
                                                     : cv::Mat(kSizes[f.size], CV_8UC1, cv::Scalar(77));
            assert_true(cv::imwrite(p.string(), m));
        } else {
            const float v[8] = {5, 1, 0.5f, 0.2f, 7, -1, 0.3f, 0.4f};
            write_bytes(p, std::string(reinterpret_cast<const char *>(v), sizeof v));
        }
        break;
    case Kind::Absent: break;
    case Kind::Fifo: assert_int_equal(mkfifo(p.c_str(), 0644), 0); break;
    case Kind::Folder: fs::create_directory(p); break;
    case Kind::Loop: fs::create_symlink(p.filename(), p); break;
    case Kind::Dangling: fs::create_symlink("nowhere", p); break;
    case Kind::DevZero: fs::create_symlink("/dev/zero", p); break;
    case Kind::Empty: write_bytes(p, ""); break;
    case Kind::Garbage: write_bytes(p, image ? "not an image at all" : "17 bytes of junk!"); break;
    case Kind::Huge:
        write_bytes(p, "");
        fs::resize_file(p, uintmax_t{100} << 30);
        break;
    }
}

bool valid_image(const FileSpec &f) {
    return f.kind == Kind::Valid || f.kind == Kind::OtherSize || f.kind == Kind::Colour;
}

// The reason a bad file of this kind gives (a substring of it).
std::string reason_of(const FileSpec &f, bool image) {
    switch (f.kind) {
    case Kind::Absent:
    case Kind::Dangling: return "missing";
    case Kind::Fifo: return "is a FIFO, not a regular file";
    case Kind::Folder: return "is a folder, not a regular file";
    case Kind::Loop: return "Too many levels of symbolic links";
    case Kind::DevZero: return "is a character device, not a regular file";
    case Kind::Empty: return image ? "not an image file" : "empty Velodyne scan";
    case Kind::Garbage: return image ? "not an image file" : "is not a multiple of 16";
    case Kind::Huge: return "is more than a scan's";
    default: return "the drive's frames are";
    }
}

Kind random_kind(std::mt19937 &rng, bool image, bool right) {
    if (rng() % 4 != 0) return Kind::Valid;  // most files are good: good frames are tested too
    std::vector<Kind> kinds = {Kind::Absent, Kind::Fifo,    Kind::Folder, Kind::Loop,
                               Kind::Dangling, Kind::DevZero, Kind::Empty, Kind::Garbage};
    if (image) kinds.push_back(Kind::OtherSize);
    if (right) kinds.push_back(Kind::Colour);
    if (!image) kinds.push_back(Kind::Huge);
    return kinds[std::uniform_int_distribution<size_t>(0, kinds.size() - 1)(rng)];
}

void on_alarm(int) {
    static const char msg[] = "test_drive_folder: a reader blocked (alarm)\n";
    (void)!write(2, msg, sizeof msg - 1);
    _exit(1);
}

struct Tally {
    int frames = 0, good = 0, misnamed = 0;
    std::set<std::string> reasons;
};

void check_drive(unsigned seed, Tally &tally) {
    std::mt19937 rng(seed);
    const fs::path root = test::scratch_dir("drive_folder/" + std::to_string(seed));
    const char *dirs[3] = {"image_02/data", "image_03/data", "velodyne_points/data"};
    const bool has_dir[3] = {true, rng() % 8 != 0, rng() % 8 != 0};
    for (int i = 0; i < 3; ++i)
        if (has_dir[i]) fs::create_directories(root / dirs[i]);

    std::map<long, FrameSpec> frames;
    const int count = 2 + static_cast<int>(rng() % 6);
    while (static_cast<int>(frames.size()) < count) {
        FrameSpec f;
        f.left = {random_kind(rng, true, false), 0};
        f.right = {random_kind(rng, true, true), 0};
        f.scan = {random_kind(rng, false, false), 0};
        for (FileSpec *s : {&f.left, &f.right})
            if (s->kind == Kind::OtherSize) s->size = 1;
        if (!has_dir[1]) f.right.kind = Kind::Absent;
        if (!has_dir[2]) f.scan.kind = Kind::Absent;
        frames[static_cast<long>(rng() % 40)] = f;
    }
    std::set<long> listed;
    for (const auto &[k, f] : frames) {
        make_file(root / io::drive_left_file(k), f.left, true);
        if (has_dir[1]) make_file(root / io::drive_right_file(k), f.right, true);
        if (has_dir[2]) make_file(root / io::drive_scan_file(k), f.scan, false);
        if (f.left.kind != Kind::Absent || f.right.kind != Kind::Absent || f.scan.kind != Kind::Absent)
            listed.insert(k);
    }
    // Misnamed (a leading digit) and foreign names; FIFOs among them must not be opened either.
    std::set<std::string> misnamed;
    const std::vector<std::string> odd = {"00000000001.png", "000000002.png", "0000000003.jpg", "0000000004.png.bak",
                                          "12abc", "000000000000000000000000000005.png"};
    for (int i = 0; i < 3; ++i) {
        if (!has_dir[i]) continue;
        if (rng() % 2) {
            const std::string n = odd[rng() % odd.size()];
            assert_int_equal(mkfifo((root / dirs[i] / n).c_str(), 0644), 0);
            misnamed.insert(std::string(dirs[i]) + "/" + n);
        }
        if (rng() % 2) write_bytes(root / dirs[i] / "README.txt", "foreign");
        if (rng() % 2) write_bytes(root / dirs[i] / ".0000000001.png", "hidden");
    }

    const io::DriveListing l = io::list_drive(root.string());
    assert_true(std::set<long>(l.frames.begin(), l.frames.end()) == listed);
    assert_int_equal(l.frames.size(), listed.size());
    std::set<std::string> got_misnamed;
    for (const io::MisnamedFile &m : l.misnamed) got_misnamed.insert(m.file);
    assert_true(got_misnamed == misnamed);
    tally.misnamed += static_cast<int>(misnamed.size());

    // The most common valid left size; ties to the earliest frame of either.
    int votes[2] = {0, 0};
    long first_of[2] = {-1, -1};
    for (long k : l.frames) {
        const FileSpec &s = frames[k].left;
        if (!valid_image(s)) continue;
        ++votes[s.size];
        if (first_of[s.size] < 0) first_of[s.size] = k;
    }
    cv::Size expected_size;
    if (votes[0] + votes[1] > 0) {
        const int best = votes[0] != votes[1] ? (votes[0] > votes[1] ? 0 : 1)
                         : (first_of[1] < 0 || (first_of[0] >= 0 && first_of[0] < first_of[1]) ? 0 : 1);
        expected_size = kSizes[best];
    }
    const cv::Size size = io::drive_frame_size(root.string(), l.frames);
    assert_true(size == expected_size);

    for (long k : l.frames) {
        const FrameSpec &f = frames[k];
        std::string file, reason, scan_reason;
        const auto image_problem = [&](const FileSpec &s, const std::string &rel) {
            if (!valid_image(s)) return (file = rel, reason = reason_of(s, true), true);
            if (kSizes[s.size] != size) return (file = rel, reason = "the drive's frames are", true);
            return false;
        };
        if (!image_problem(f.left, io::drive_left_file(k)) && !image_problem(f.right, io::drive_right_file(k))) {
            if (f.right.kind == Kind::Colour) {
                file = io::drive_right_file(k);
                reason = "is colour but the left image is gray";
            } else if (f.scan.kind != Kind::Valid) {
                scan_reason = reason_of(f.scan, false);  // the frame stays good, without points
            }
        }
        io::DriveFrame frame;
        io::DriveFileError error;
        const bool ok = io::read_drive_frame(root.string(), k, size, frame, error);
        if (ok != file.empty() || (!ok && (error.file != file || error.reason.find(reason) == std::string::npos)))
            fail_msg("seed %u, frame %ld: expected %s%s%s, got %s: %s", seed, k, file.empty() ? "a good frame" : file.c_str(),
                     file.empty() ? "" : ": ", reason.c_str(), ok ? "a good frame" : error.file.c_str(), error.reason.c_str());
        if (ok && (scan_reason.empty() ? !frame.scan_error.file.empty() || frame.scan.points.size() != 2
                                       : frame.scan_error.file != io::drive_scan_file(k) ||
                                             frame.scan_error.reason.find(scan_reason) == std::string::npos ||
                                             !frame.scan.points.empty()))
            fail_msg("seed %u, frame %ld: expected the scan %s, got %zu points, error '%s: %s'", seed, k,
                     scan_reason.empty() ? "good" : scan_reason.c_str(), frame.scan.points.size(),
                     frame.scan_error.file.c_str(), frame.scan_error.reason.c_str());
        if (ok) assert_true(frame.left.size() == size);
        if (!scan_reason.empty()) tally.reasons.insert(scan_reason);
        ++tally.frames;
        tally.good += ok ? 1 : 0;
        if (!ok) tally.reasons.insert(reason);
    }
}

void test_random_drives(void **) {
    std::signal(SIGALRM, on_alarm);
    alarm(120);
    Tally tally;
    for (unsigned seed = 1; seed <= 60; ++seed) check_drive(seed, tally);
    alarm(0);
    std::printf("60 drives: %d frames read, %d good, %d misnamed names, %zu kinds of bad frame\n", tally.frames,
                tally.good, tally.misnamed, tally.reasons.size());
    // The seeds reach good frames and every reason of a bad one (absent and dangling: "missing").
    assert_true(tally.good >= 40 && tally.reasons.size() == 11 && tally.misnamed >= 30);
}

// Timestamps: absent is silent, a good file parses, the rest say why and give no times.
void test_timestamps(void **) {
    const fs::path root = test::scratch_dir("drive_folder/stamps");
    fs::create_directories(root / "image_02");
    const fs::path t = root / "image_02/timestamps.txt";
    io::DriveTimestamps s = io::read_drive_timestamps(root.string());
    assert_true(s.seconds.empty() && s.problem.empty());
    write_bytes(t, "2011-09-26 13:02:25.964389445\n2011-09-26 13:02:26.068000000\n");
    s = io::read_drive_timestamps(root.string());
    assert_int_equal(s.seconds.size(), 2);
    assert_true(std::fabs(s.seconds[1] - s.seconds[0] - 0.103610555) < 1e-6 && s.problem.empty());
    write_bytes(t, "2011-09-26 13:02:25.9\nnot a time\n");
    s = io::read_drive_timestamps(root.string());
    assert_true(s.seconds.empty() && s.problem.find("line 2") != std::string::npos);
    fs::remove(t);
    fs::create_symlink("/dev/zero", t);
    s = io::read_drive_timestamps(root.string());
    assert_true(s.seconds.empty() && s.problem.find("character device") != std::string::npos);
    fs::remove(t);
    write_bytes(t, "");
    fs::resize_file(t, uintmax_t{1} << 30);
    s = io::read_drive_timestamps(root.string());
    assert_true(s.seconds.empty() && s.problem.find("larger than") != std::string::npos);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_drives),
        cmocka_unit_test(test_timestamps),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
