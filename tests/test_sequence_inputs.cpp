// SPDX-License-Identifier: MIT
// `lidarflow sequence` on a synthetic drive (`synth --drive`) broken at run time, one way per
// test: every bad frame file is a reported bad frame (exit 3) with the other pairs computed, never
// a hang, an abort or a silent drop; bad calibration is exit 1 naming the file; --skip-existing
// keeps only results its manifest vouches for with the same settings.
//  - FIFOs as a scan, an image, image_02/timestamps.txt, a calibration file, and (in a mount
//    namespace, when unshare works) bound over /proc/loadavg with adaptive threads;
//    /dev/zero as timestamps.txt;
//  - a 100 GiB sparse scan, a symlink loop, a folder without permission, a folder as a scan (a bad scan: its pairs image-only);
//  - an odd-sized first frame; a missing left image of the last frame; an 11-digit name;
//  - R_rect_00 scaled or zero, a velo T of 1e30, a non-pinhole P_rect_02;
//  - a failed write leaves no temporary file; --skip-existing and its manifest.
// Every CLI run goes through `timeout`, so a blocking open fails the test instead of hanging it.
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lidarflow/lidarflow.h"
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

std::string q(const fs::path &p) { return test::quoted(p); }

std::string name(int k) { return test::frame_name(k); }
constexpr auto expect_code = test::expect_exit;
constexpr auto expect_contains = test::expect_output_has;

fs::path &base_dir() {
    static fs::path dir;
    return dir;
}

// The five-frame drive every test copies and breaks.
const fs::path &drive() {
    static fs::path d;
    if (!d.empty()) return d;
    base_dir() = test::scratch_dir("sequence_inputs");
    d = base_dir() / "drive";
    expect_code(test::run_cli("synth --drive " + q(d) + " --frames 5 --width 320 --height 96 --seed 4"), 0);
    return d;
}

fs::path copy_of_drive(const std::string &label) {
    const fs::path &from = drive();  // first: it sets base_dir(), whose empty path was the working folder
    const fs::path to = base_dir() / label;
    fs::remove_all(to);
    fs::copy(from, to, fs::copy_options::recursive);
    return to;
}

using test::run_shell;

// "timeout 120 'CLI' sequence --drive D --out OUT" with the realtime preset and npy files: a
// blocked run ends with 124.
std::string sequence_command(const fs::path &d, const fs::path &out) {
    const char *cli = std::getenv("LIDARFLOW_CLI");
    if (!cli || !*cli) fail_msg("LIDARFLOW_CLI is not set (run through ctest)");
    return "timeout 120 '" + std::string(cli) + "' sequence --drive " + q(d) + " --out " + q(out) +
           " --format npy --threads 2 --preset realtime";
}

test::CliRun sequence(const fs::path &d, const fs::path &out, const std::string &extra = "") {
    return run_shell(sequence_command(d, out) + " " + extra);
}

void replace_with_fifo(const fs::path &p) {
    fs::remove(p);
    assert_int_equal(mkfifo(p.c_str(), 0644), 0);
}

void test_fifos_are_bad_frames(void **) {
    const fs::path d = copy_of_drive("fifo");
    replace_with_fifo(d / "velodyne_points/data" / (name(1) + ".bin"));
    replace_with_fifo(d / "image_03/data" / (name(3) + ".png"));
    replace_with_fifo(d / "image_02/timestamps.txt");
    const test::CliRun r = sequence(d, base_dir() / "fifo_out");
    expect_code(r, 3);
    // A bad scan costs the points only: its pairs go image-only.
    expect_contains(r, "frame 0000000001: velodyne_points/data/0000000001.bin: is a FIFO, not a regular file; pairs "
                       "0->1, 1->2 image-only");
    expect_contains(r, "frame 0000000003: image_03/data/0000000003.png: is a FIFO, not a regular file; pairs 2->3, "
                       "3->4 skipped");
    expect_contains(r, "image_02/timestamps.txt: is a FIFO, not a regular file; progress lines without frame times");
    expect_contains(r, "4 pairs: 2 computed (2 image-only), 0 skipped (existing), 2 failed");
}

void test_timestamps_of_dev_zero(void **) {
    const fs::path d = copy_of_drive("zero");
    fs::remove(d / "image_02/timestamps.txt");
    fs::create_symlink("/dev/zero", d / "image_02/timestamps.txt");
    const test::CliRun r = sequence(d, base_dir() / "zero_out", "--frames 0:1");
    expect_code(r, 0);  // the times only annotate: every pair is computed
    expect_contains(r, "image_02/timestamps.txt: is a character device, not a regular file");
    expect_contains(r, "1 pairs: 1 computed");
}

// A FIFO bound over /proc/loadavg in a private mount namespace: adaptive threads read it per frame.
void test_loadavg_fifo(void **) {
    const fs::path d = drive(), fifo = base_dir() / "loadavg.fifo";
    fs::remove(fifo);
    assert_int_equal(mkfifo(fifo.c_str(), 0644), 0);
    if (std::system(("unshare -rm sh -c 'mount --bind " + q(fifo) + " /proc/loadavg' 2>/dev/null").c_str()) != 0) {
        std::printf("unshare / mount --bind not permitted here: skipped\n");
        skip();
    }
    const std::string inner = "mount --bind " + q(fifo) + " /proc/loadavg && exec " +
                              sequence_command(d, base_dir() / "loadavg_out") +
                              " --frames 0:2 --option adaptive_threads=1";
    std::string quoted_inner;
    for (char c : inner) quoted_inner += c == '\'' ? std::string("'\\''") : std::string(1, c);
    const test::CliRun r = run_shell("unshare -rm sh -c '" + quoted_inner + "'");
    expect_code(r, 0);
    expect_contains(r, "2 pairs: 2 computed");
}

void test_huge_loop_and_folder_files(void **) {
    const fs::path d = copy_of_drive("huge");
    fs::resize_file(d / "velodyne_points/data" / (name(0) + ".bin"), uintmax_t{100} << 30);  // sparse
    fs::remove(d / "velodyne_points/data" / (name(4) + ".bin"));
    fs::create_directory(d / "velodyne_points/data" / (name(4) + ".bin"));
    const test::CliRun r = sequence(d, base_dir() / "huge_out");
    expect_code(r, 3);
    expect_contains(r, "frame 0000000000: velodyne_points/data/0000000000.bin: size 107374182400 bytes is more than "
                       "a scan's");
    expect_contains(r, "frame 0000000004: velodyne_points/data/0000000004.bin: is a folder, not a regular file");
    expect_contains(r, "[1/4] 0->1 image-only in");
    expect_contains(r, "4 pairs: 4 computed (2 image-only), 0 skipped (existing), 0 failed");
    // With the scan readable again --skip-existing recomputes its pair; the other image-only one
    // (scan 4 still a folder) stays, as do the pairs with points.
    fs::copy_file(drive() / "velodyne_points/data" / (name(0) + ".bin"), d / "velodyne_points/data" / (name(0) + ".bin"),
                  fs::copy_options::overwrite_existing);
    const test::CliRun again = sequence(d, base_dir() / "huge_out", "--skip-existing");
    expect_code(again, 3);
    expect_contains(again, "[1/4] 0->1 in");
    expect_contains(again, "4 pairs: 1 computed, 3 skipped (existing), 0 failed");
    // A file that cannot be opened for a symlink loop is one bad frame too.
    const fs::path loop = d / "image_03/data" / (name(2) + ".png");
    fs::remove(loop);
    fs::create_symlink(loop.filename(), loop);
    const test::CliRun l = sequence(d, base_dir() / "huge_out", "--frames 1:3");
    expect_code(l, 3);
    expect_contains(l, "frame 0000000002: image_03/data/0000000002.png: Too many levels of symbolic links");
    expect_contains(l, "2 pairs: 0 computed, 0 skipped (existing), 2 failed");
    // The trajectory starts at the range's first frame and ends where the pairs do.
    expect_contains(l, "sequence: poses_0000000001-0000000003.txt: frames 1..1 only (pair 1->2 has no ego-motion)");
}

// A folder whose files cannot be reached (no permission): each frame is bad, nothing aborts. As
// root the CLI runs as nobody (setpriv), since root passes every permission check.
void test_unreadable_folder(void **) {
    const fs::path d = copy_of_drive("unreadable"), out = base_dir() / "unreadable_out";
    fs::remove_all(out);
    fs::create_directories(out);
    fs::permissions(out, fs::perms::all);
    fs::permissions(d / "image_03/data", fs::perms::none);
    std::string as_other_user;
    if (geteuid() == 0) {
        if (std::system("setpriv --reuid=65534 --regid=65534 --clear-groups true 2>/dev/null") != 0) {
            fs::permissions(d / "image_03/data", fs::perms::owner_all);
            std::printf("running as root without setpriv: skipped\n");
            skip();
        }
        as_other_user = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
    }
    const test::CliRun r = run_shell(as_other_user + sequence_command(d, out) + " --frames 0:1");
    fs::permissions(d / "image_03/data", fs::perms::owner_all);
    expect_code(r, 3);
    expect_contains(r, "frame 0000000000: image_03/data/0000000000.png: Permission denied; pair 0->1 skipped");
    expect_contains(r, "1 pairs: 0 computed, 0 skipped (existing), 1 failed");
}

void test_odd_first_frame(void **) {
    const fs::path d = copy_of_drive("odd");
    for (const char *cam : {"image_02/data", "image_03/data"}) {
        const fs::path p = d / cam / (name(0) + ".png");
        cv::Mat m = cv::imread(p.string(), cv::IMREAD_UNCHANGED), small;
        cv::resize(m, small, cv::Size(160, 48));
        assert_true(cv::imwrite(p.string(), small));
    }
    const test::CliRun r = sequence(d, base_dir() / "odd_out");
    expect_code(r, 3);
    expect_contains(r, "frame 0000000000: image_02/data/0000000000.png: is 160x48, the drive's frames are 320x96; "
                       "pair 0->1 skipped");
    expect_contains(r, "4 pairs: 3 computed, 0 skipped (existing), 1 failed");
}

void test_missing_last_left_and_misnamed(void **) {
    const fs::path d = copy_of_drive("names");
    fs::remove(d / "image_02/data" / (name(4) + ".png"));
    const test::CliRun r = sequence(d, base_dir() / "names_out", "--frames 2:4");
    expect_code(r, 3);
    expect_contains(r, "frame 0000000004: image_02/data/0000000004.png: missing; pair 3->4 skipped");
    expect_contains(r, "2 pairs: 1 computed, 0 skipped (existing), 1 failed");
    // Without --frames the range ends at the last frame of any data folder.
    const test::CliRun all = sequence(d, base_dir() / "names_out", "--skip-existing");
    expect_code(all, 3);
    expect_contains(all, "frame 0000000004: image_02/data/0000000004.png: missing; pair 3->4 skipped");
    // A frame named with 11 digits is reported, not dropped unseen.
    fs::rename(d / "image_03/data" / (name(1) + ".png"), d / "image_03/data" / ("0" + name(1) + ".png"));
    const test::CliRun m = sequence(d, base_dir() / "names_out", "--frames 0:1");
    expect_code(m, 3);
    expect_contains(m, "sequence: image_03/data/00000000001.png: not a frame's name");
    expect_contains(m, "frame 0000000001: image_03/data/0000000001.png: missing; pair 0->1 skipped");
}

void write_text(const fs::path &p, const std::string &text) {
    fs::remove(p);
    std::ofstream(p) << text;
}

// calib_cam_to_cam.txt of the drive with one line replaced.
std::string cam_to_cam_with(const std::string &key, const std::string &values) {
    std::ifstream in(drive() / "calib_cam_to_cam.txt");
    std::string line, text;
    while (std::getline(in, line)) text += (line.rfind(key + ":", 0) == 0 ? key + ": " + values : line) + "\n";
    return text;
}

void test_bad_calibration_is_exit_1(void **) {
    const fs::path d = copy_of_drive("calib");
    const fs::path cam = d / "calib_cam_to_cam.txt", velo = d / "calib_velo_to_cam.txt";
    const std::string cam_path = cam.string();
    struct Case {
        fs::path file;
        std::string text, says;
    };
    const std::vector<Case> cases = {
        {cam, cam_to_cam_with("R_rect_00", "1e300 0 0 0 1e300 0 0 0 1e300"), "R_rect_00 is not a rotation matrix"},
        {cam, cam_to_cam_with("R_rect_00", "0 0 0 0 0 0 0 0 0"), "R_rect_00 is not a rotation matrix"},
        {cam, cam_to_cam_with("P_rect_02", "300 0 160 0 0 300 48 0 0 0 2 0"), "P_rect_02 is not a rectified pinhole"},
        {velo, "R: 1 0 0 0 1 0 0 0 1\nT: 1e30 0 0\n", "T moves the LiDAR more than 1000 m"},
    };
    for (const Case &c : cases) {
        fs::copy_file(drive() / c.file.filename(), c.file, fs::copy_options::overwrite_existing);
        write_text(c.file, c.text);
        const test::CliRun r = sequence(d, base_dir() / "calib_out", "--frames 0:1");
        expect_code(r, 1);
        expect_contains(r, c.file.string() + ": " + c.says);
        fs::copy_file(drive() / c.file.filename(), c.file, fs::copy_options::overwrite_existing);
    }
    replace_with_fifo(cam);
    const test::CliRun r = sequence(d, base_dir() / "calib_out", "--frames 0:1");
    expect_code(r, 1);
    expect_contains(r, "cannot open " + cam_path + ": is a FIFO, not a regular file");
    // The C ABI's reader (and so Calibration::read_kitti) refuses it too, without waiting.
    lf_calibration_t cal;
    lf_calibration_init(&cal);
    assert_int_equal(lf_read_kitti_calibration(cam.c_str(), nullptr, &cal), LF_ERR_IO);
    assert_non_null(std::strstr(lf_last_error(nullptr), "is a FIFO"));
}

void test_failed_write_leaves_no_temporary(void **) {
    const fs::path out = base_dir() / "unwritable_out";
    fs::remove_all(out);
    fs::create_directories(out);
    write_text(out / "flow", "a file where the flow folder goes\n");
    const test::CliRun r = sequence(drive(), out, "--frames 0:1");
    expect_code(r, 1);
    for (const std::string &t : test::temporaries(out)) fail_msg("temporary file left: %s", t.c_str());
}

std::string file_bytes(const fs::path &p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

void test_skip_existing_trusts_only_its_manifest(void **) {
    const fs::path out = base_dir() / "skip_out";
    fs::remove_all(out);
    expect_contains(sequence(drive(), out, "--frames 0:3"), "3 pairs: 3 computed");
    const std::string flow1 = file_bytes(out / "flow" / (name(1) + ".npy"));
    fs::resize_file(out / "disp_0" / (name(0) + ".npy"), 0);  // a 0-byte result
    {
        std::fstream f(out / "flow" / (name(1) + ".npy"), std::ios::in | std::ios::out | std::ios::binary);
        f.seekg(-3, std::ios::end);
        const char c = static_cast<char>(f.get() ^ 0x10);
        f.seekp(-3, std::ios::end);
        f.put(c);  // a corrupt one of the right size
    }
    const test::CliRun a = sequence(drive(), out, "--frames 0:3 --skip-existing");
    expect_code(a, 0);
    expect_contains(a, "3 pairs: 2 computed, 1 skipped (existing), 0 failed");
    expect_contains(a, "2->3 exists, skipped");
    assert_true(file_bytes(out / "flow" / (name(1) + ".npy")) == flow1);
    assert_true(fs::file_size(out / "disp_0" / (name(0) + ".npy")) > 0);
    expect_contains(sequence(drive(), out, "--frames 0:3 --skip-existing"), "3 pairs: 0 computed, 3 skipped");
    for (int k : {0, 1, 2}) assert_true(fs::is_regular_file(out / "manifest" / (name(k) + ".txt")));
    // Results of another preset or option are not this run's.
    expect_contains(sequence(drive(), out, "--frames 0:1 --skip-existing --preset fast"), "1 pairs: 1 computed");
    expect_contains(sequence(drive(), out, "--frames 1:2 --skip-existing --option use_lidar=0"), "1 pairs: 1 computed");
    // A format the manifest does not list is computed.
    expect_contains(sequence(drive(), out, "--frames 2:3 --skip-existing --format kitti"), "1 pairs: 1 computed");
    assert_true(test::temporaries(out).empty());
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fifos_are_bad_frames),
        cmocka_unit_test(test_timestamps_of_dev_zero),
        cmocka_unit_test(test_loadavg_fifo),
        cmocka_unit_test(test_huge_loop_and_folder_files),
        cmocka_unit_test(test_unreadable_folder),
        cmocka_unit_test(test_odd_first_frame),
        cmocka_unit_test(test_missing_last_left_and_misnamed),
        cmocka_unit_test(test_bad_calibration_is_exit_1),
        cmocka_unit_test(test_failed_write_leaves_no_temporary),
        cmocka_unit_test(test_skip_existing_trusts_only_its_manifest),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
