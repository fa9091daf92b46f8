// SPDX-License-Identifier: MIT
// The CLI's input boundary, end to end: oversized images (65535x2 PNGs crashed `lidarflow run`
// inside SGM), files in no image format it reads, calibrations whose derived baseline overflows
// (exit 0 before), frame ids that would leave the layout, and output folders that cannot be
// written: each a clear message and a non-zero exit, found before any estimation.
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "io/kitti_layout.hpp"
#include "test_support.hpp"

using namespace lidarflow;
namespace fs = std::filesystem;

namespace {

using Result = test::CliRun;

// The scratch dir names where a test's files go; the output comes back through a pipe.
Result run(const std::string &args, const fs::path &) { return test::run_cli(args); }

std::string q(const fs::path &p) { return test::quoted(p); }

void expect_failure(const Result &r, int code, const char *needle) {
    if (r.code == code && r.output.find(needle) != std::string::npos) return;
    std::printf("%s", r.output.c_str());
    fail_msg("exit %d (expected %d) or no '%s' in the output above", r.code, code, needle);
}

// A synthetic KITTI-layout frame 000000 under dir/kitti.
fs::path synth_frame(const fs::path &dir) {
    const fs::path root = dir / "kitti";
    const Result r = run("synth --out " + q(root) + " --width 160 --height 64 --points 40", dir);
    if (r.code != 0) fail_msg("synth failed (%d): %s", r.code, r.output.c_str());
    return root;
}

std::string run_args(const fs::path &root) {
    const io::KittiLayout k{root.string()};
    return "run --left0 " + q(k.left("000000", 0)) + " --right0 " + q(k.right("000000", 0)) + " --left1 " +
           q(k.left("000000", 1)) + " --right1 " + q(k.right("000000", 1));
}

void run_refuses_oversized_and_unknown_images(void **) {
    const fs::path dir = test::scratch_dir("cli_limits_images");
    const fs::path wide = dir / "wide.png";
    assert_true(cv::imwrite(wide.string(), cv::Mat(2, 65535, CV_8UC1, cv::Scalar(9))));
    const std::string four = " --left0 " + q(wide) + " --right0 " + q(wide) + " --left1 " + q(wide) + " --right1 " + q(wide);
    // An input, not the command line: exit 1 (2 is for a bad command line).
    expect_failure(run("run" + four + " --out " + q(dir / "out"), dir), 1, "is 65535x2, larger than 16384 px per side");

    // A format outside PNG, JPEG, BMP and PNM (here a GIF's signature) never reaches a decoder,
    // whatever its name.
    const fs::path fake = dir / "image.png";
    std::ofstream(fake, std::ios::binary) << "GIF89a" << std::string(64, '\0');
    const std::string fakes = " --left0 " + q(fake) + " --right0 " + q(fake) + " --left1 " + q(fake) + " --right1 " + q(fake);
    expect_failure(run("run" + fakes + " --out " + q(dir / "out"), dir), 1,
                   "not an image file this reads (PNG, JPEG, BMP, PGM/PPM; by signature)");
}

void run_refuses_a_calibration_whose_baseline_overflows(void **) {
    const fs::path dir = test::scratch_dir("cli_limits_calib");
    const fs::path root = synth_frame(dir);
    const fs::path calib = dir / "inf.txt";
    std::ofstream(calib) << "R_rect_00: 1 0 0 0 1 0 0 0 1\n"
                            "P_rect_02: 700 0 80 1e308 0 700 32 0 0 0 1 0\n"
                            "P_rect_03: 700 0 80 -1e308 0 700 32 0 0 0 1 0\n";
    const Result r = run(run_args(root) + " --calib " + q(calib) + " --out " + q(dir / "out"), dir);
    expect_failure(r, 1, "baseline = inf m is outside [0.0001, 10000]");
    assert_false(fs::exists(dir / "out" / "flow"));
}

void run_checks_its_id_and_output_folder_first(void **) {
    const fs::path dir = test::scratch_dir("cli_limits_run_out");
    const fs::path root = synth_frame(dir);
    std::ofstream(dir / "file") << "x";
    expect_failure(run(run_args(root) + " --out " + q(dir / "out") + " --id ../../x", dir), 2,
                   "output name '../../x' must be");
    assert_false(fs::exists(dir / "out" / "flow"));
    // Before: the estimation ran, then writing disp_0/ failed ("cannot create folder ...").
    expect_failure(run(run_args(root) + " --out " + q(dir / "file" / "out"), dir), 1, "cannot create output folder");
}

void kitti_commands_check_ids_and_output_folder_first(void **) {
    const fs::path dir = test::scratch_dir("cli_limits_kitti");
    const fs::path root = synth_frame(dir);
    std::ofstream(dir / "file") << "x";
    expect_failure(run("kitti --root " + q(root) + " --ids 000000,../../x", dir), 2,
                   "frame id '../../x' is not a KITTI frame id");
    expect_failure(run("kitti --root " + q(root) + " --ids 000000 --no-viz --out " + q(dir / "file" / "out"), dir), 1,
                   "cannot create output folder");
    expect_failure(run("eval --root " + q(root) + " --est " + q(root) + " --ids ../../x", dir), 2,
                   "is not a KITTI frame id");
    expect_failure(run("sample-lidar --root " + q(root) + " --protocol paper --ids ../x --out " + q(dir / "lidar"), dir),
                   2, "is not a KITTI frame id");
    expect_failure(run("sample-lidar --root " + q(root) + " --protocol paper --ids 000000 --out " + q(dir / "file"), dir),
                   1, "cannot create output folder");
}

// A library error of the same code (InvalidArgument) is the command line's before the command
// reads its inputs (exit 2) and the inputs' after (exit 1), as --help's exit statuses say.
void library_errors_exit_by_phase(void **) {
    const fs::path dir = test::scratch_dir("cli_limits_phase");
    const fs::path root = synth_frame(dir);
    expect_failure(run("kitti --root " + q(root) + " --ids 000000 --set interpolation.num_neighbors=0", dir), 2,
                   "interpolation.num_neighbors");
    expect_failure(run(run_args(root) + " --set interpolation.num_neighbors=0 --out " + q(dir / "out"), dir), 2,
                   "interpolation.num_neighbors");
    // Four black images: nothing to match, which the estimator finds once it runs.
    const fs::path black = dir / "black.png";
    assert_true(cv::imwrite(black.string(), cv::Mat(64, 160, CV_8UC3, cv::Scalar::all(0))));
    const std::string four = " --left0 " + q(black) + " --right0 " + q(black) + " --left1 " + q(black) +
                             " --right1 " + q(black);
    expect_failure(run("run" + four + " --no-lidar --out " + q(dir / "out"), dir), 1, "no valid match");
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(run_refuses_oversized_and_unknown_images),
        cmocka_unit_test(run_refuses_a_calibration_whose_baseline_overflows),
        cmocka_unit_test(run_checks_its_id_and_output_folder_first),
        cmocka_unit_test(kitti_commands_check_ids_and_output_folder_first),
        cmocka_unit_test(library_errors_exit_by_phase),
    };
    return cmocka_run_group_tests_name("cli_limits", tests, nullptr, nullptr);
}
