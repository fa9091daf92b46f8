// SPDX-License-Identifier: MIT
// `lidarflow run` says whether its inputs look right: one line "quality: ok" or "quality: STATE
// (reason)". Correct frames (a rendered one, and the shared KITTI frames with the real scan or
// the paper's 88 points) are ok; the usual rig mistakes, made here from those frames at run time,
// are flagged: left and right swapped, the right images rotated by 1.5 degrees and shifted by
// 6 px (not rectified), black t1 images, LiDAR disparities off by 6 px, a LiDAR-to-camera
// transform tilted by 1 degree, images cropped under the full-frame calibration. Also the
// messages around it: run's missing arguments before any image is read, colour and gray images
// together, viz's mismatched sizes. Runs the built binary ($LIDARFLOW_CLI, set by CTest).
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "io/kitti_png.hpp"
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
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

struct Pair {
    fs::path left0, right0, left1, right1;
};

// The "quality: ..." line of the output ("" when there is none).
std::string quality_line(const std::string &out) {
    const size_t at = out.find("quality: ");
    if (at == std::string::npos || (at > 0 && out[at - 1] != '\n')) return "";
    return out.substr(at, out.find('\n', at) - at);
}

// `run` on the pair at the realtime preset (callers add --stage matching where the later stages
// do not matter: the checks run before stage 1).
test::CliRun run_on(const Pair &p, const std::string &extra, const fs::path &dir) {
    return test::run_cli("run --left0 " + q(p.left0) + " --right0 " + q(p.right0) + " --left1 " + q(p.left1) +
                         " --right1 " + q(p.right1) + " --preset realtime --threads 2 " + extra + " --out " +
                         q(dir / "out"));
}

// Its output; fails the test on an exit status other than `code`.
std::string run_pair(const Pair &p, const std::string &extra, const fs::path &dir, int code = 0) {
    const test::CliRun r = run_on(p, extra, dir);
    if (r.code != code) fail_msg("exit %d (expected %d):\n%s", r.code, code, r.output.c_str());
    return r.output;
}

void expect_quality(const std::string &out, const std::string &expected_start) {
    const std::string line = quality_line(out);
    if (line.rfind(expected_start, 0) != 0)
        fail_msg("expected a line starting \"%s\", got \"%s\" in:\n%s", expected_start.c_str(), line.c_str(),
                 out.c_str());
}

void expect_contains(const std::string &out, const std::string &what) {
    if (out.find(what) == std::string::npos) fail_msg("expected \"%s\" in:\n%s", what.c_str(), out.c_str());
}

fs::path write_image(const fs::path &path, const cv::Mat &m) {
    assert_true(cv::imwrite(path.string(), m));
    return path;
}

// The image rotated by 1.5 degrees about its centre and moved down by 6 px.
cv::Mat rotate_shift(const cv::Mat &m) {
    cv::Mat R = cv::getRotationMatrix2D(cv::Point2f(m.cols / 2.0f, m.rows / 2.0f), 1.5, 1.0), out;
    R.at<double>(1, 2) += 6;
    cv::warpAffine(m, out, R, m.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    return out;
}

Pair swapped(const Pair &p) { return {p.right0, p.left0, p.right1, p.left1}; }

Pair not_rectified(const Pair &p, const fs::path &dir) {
    return {p.left0, write_image(dir / "rot0.png", rotate_shift(cv::imread(p.right0.string(), cv::IMREAD_UNCHANGED))),
            p.left1, write_image(dir / "rot1.png", rotate_shift(cv::imread(p.right1.string(), cv::IMREAD_UNCHANGED)))};
}

Pair black_t1(const Pair &p, const fs::path &dir) {
    const cv::Mat m = cv::imread(p.left1.string(), cv::IMREAD_UNCHANGED);
    const fs::path black = write_image(dir / "black.png", cv::Mat::zeros(m.size(), m.type()));
    return {p.left0, p.right0, black, black};
}

// Frames that a broken camera delivers make the estimator fail or produce nonsense: either way
// the state is named, in the quality line or in the error message.
void expect_blank(const Pair &p, const std::string &extra, const fs::path &dir) {
    const test::CliRun r = run_on(p, extra, dir);
    if (r.code == 0)
        expect_quality(r.output, "quality: blank_frame (left1 is black");
    else
        expect_contains(r.output, "(input quality: blank_frame (left1 is black");
}

void synthetic_frames(void **) {
    const fs::path dir = test::scratch_dir("quality_cli_synth");
    const test::CliRun s = test::run_cli("synth --out " + q(dir / "k") + " --quiet");
    assert_int_equal(s.code, 0);
    const fs::path k = dir / "k";
    const Pair p{k / "image_2/000000_10.png", k / "image_3/000000_10.png", k / "image_2/000000_11.png",
                 k / "image_3/000000_11.png"};
    const std::string lidar = "--lidar0 " + q(k / "lidar_0/000000_10.png") + " --calib " +
                              q(k / "calib_cam_to_cam/000000.txt");
    expect_quality(run_pair(p, lidar + " --stage matching", dir), "quality: ok");
    expect_quality(run_pair(swapped(p), "--no-lidar --stage matching", dir), "quality: left_right_swapped (");
    expect_quality(run_pair(not_rectified(p, dir), lidar + " --stage matching", dir), "quality: not_rectified (");
    expect_blank(black_t1(p, dir), lidar, dir);
    // The LiDAR 6 px off: the images disagree with it.
    DisparityMap d = io::read_disparity_png((k / "lidar_0/000000_10.png").string());
    d.setTo(0, d < 0);
    cv::Mat1f off = d + 6.0f;
    off.setTo(-1.0f, d <= 0);
    io::write_disparity_png((dir / "off.png").string(), off);
    expect_quality(run_pair(p, "--lidar0 " + q(dir / "off.png") + " --stage matching", dir),
                   "quality: lidar_disagrees (");
}

// The real frames, with their scan through the calibration files.
void kitti_frames(void **) {
    if (test::kitti_dir().empty()) {
        std::printf("KITTI frames not available (LIDARFLOW_KITTI_DIR): skipped\n");
        skip();
    }
    const fs::path root = test::kitti_dir(), dir = test::scratch_dir("quality_cli_kitti");
    const auto pair_of = [&](const std::string &id) {
        return Pair{root / ("image_2/" + id + "_10.png"), root / ("image_3/" + id + "_10.png"),
                    root / ("image_2/" + id + "_11.png"), root / ("image_3/" + id + "_11.png")};
    };
    const auto scan = [&](const std::string &id, const fs::path &velo_calib) {
        return "--calib " + q(root / ("calib_cam_to_cam/" + id + ".txt")) + " --calib-velo " + q(velo_calib) +
               " --velo0 " + q(root / ("velodyne/" + id + ".bin"));
    };
    for (const std::string id : {"000002", "000003"})
        expect_quality(run_pair(pair_of(id), scan(id, root / ("calib_velo_to_cam/" + id + ".txt")) + " --stage matching",
                                dir),
                       "quality: ok");
    const Pair p = pair_of("000002");
    const std::string velo = scan("000002", root / "calib_velo_to_cam/000002.txt");
    expect_quality(run_pair(swapped(p), velo + " --stage matching", dir), "quality: left_right_swapped (");
    expect_quality(run_pair(not_rectified(p, dir), velo + " --stage matching", dir), "quality: not_rectified (");
    expect_blank(black_t1(p, dir), velo, dir);

    // The LiDAR tilted by 1 degree about the camera's x axis.
    {
        std::ifstream in(root / "calib_velo_to_cam/000002.txt");
        std::string line;
        double R[9] = {}, T[3] = {};
        while (std::getline(in, line)) {
            if (line.rfind("R:", 0) == 0)
                std::sscanf(line.c_str() + 2, "%lf %lf %lf %lf %lf %lf %lf %lf %lf", &R[0], &R[1], &R[2], &R[3], &R[4],
                            &R[5], &R[6], &R[7], &R[8]);
            if (line.rfind("T:", 0) == 0) std::sscanf(line.c_str() + 2, "%lf %lf %lf", &T[0], &T[1], &T[2]);
        }
        const double a = 1.0 * CV_PI / 180, c = std::cos(a), s = std::sin(a);
        const cv::Matx33d tilt(1, 0, 0, 0, c, -s, 0, s, c), Rt = tilt * cv::Matx33d(R);
        const cv::Vec3d Tt = tilt * cv::Vec3d(T[0], T[1], T[2]);
        std::ofstream out(dir / "velo_tilted.txt");
        out.precision(12);
        out << "R:";
        for (int i = 0; i < 9; ++i) out << ' ' << Rt.val[i];
        out << "\nT: " << Tt[0] << ' ' << Tt[1] << ' ' << Tt[2] << '\n';
    }
    expect_quality(run_pair(p, scan("000002", dir / "velo_tilted.txt") + " --stage matching", dir),
                   "quality: lidar_disagrees (");

    // Cropped (as a region of interest would be) under the full-frame calibration: its S_rect_02
    // says 1242x375, and the scan lands 120 px left of and 21 px above where the images show it.
    Pair crop;
    fs::path *paths[4] = {&crop.left0, &crop.right0, &crop.left1, &crop.right1};
    const fs::path full[4] = {p.left0, p.right0, p.left1, p.right1};
    for (int i = 0; i < 4; ++i)
        *paths[i] = write_image(dir / ("crop" + std::to_string(i) + ".png"),
                                cv::imread(full[i].string(), cv::IMREAD_UNCHANGED)(cv::Rect(120, 21, 1001, 333)));
    expect_quality(run_pair(crop, velo + " --stage matching", dir), "quality: calibration_size_mismatch, lidar_disagrees (");

    // The paper's 88 points of both frames: no false alarm (the warning would be in the log).
    const test::CliRun k = test::run_cli("kitti --root " + q(root) +
                                         " --lidar paper --preset realtime --stage matching --threads 2 --no-viz --verbose");
    if (k.code != 0) fail_msg("%s", k.output.c_str());
    if (k.output.find("warning: input quality") != std::string::npos) fail_msg("false alarm:\n%s", k.output.c_str());
}

void run_messages(void **) {
    const fs::path dir = test::scratch_dir("quality_cli_messages");
    // A missing argument is reported before the (here unreadable) images are opened.
    test::CliRun r = test::run_cli("run --left0 " + q(dir / "missing.png") + " --out " + q(dir / "out"));
    assert_int_equal(r.code, 2);
    expect_contains(r.output, "missing required option --right0");
    assert_true(r.output.find("missing.png") == std::string::npos);

    const test::CliRun s = test::run_cli("synth --out " + q(dir / "k") + " --quiet");
    assert_int_equal(s.code, 0);
    const fs::path k = dir / "k";
    // Colour left images (as synth writes them) with gray right ones: said before estimating,
    // then matched in gray.
    const Pair p{k / "image_2/000000_10.png", k / "image_3/000000_10.png", k / "image_2/000000_11.png",
                 k / "image_3/000000_11.png"};
    assert_int_equal(cv::imread(p.left0.string(), cv::IMREAD_UNCHANGED).channels(), 3);
    Pair mixed = p;
    mixed.right0 = write_image(dir / "right0_gray.png", cv::imread(p.right0.string(), cv::IMREAD_GRAYSCALE));
    mixed.right1 = write_image(dir / "right1_gray.png", cv::imread(p.right1.string(), cv::IMREAD_GRAYSCALE));
    const std::string out = run_pair(mixed, "--stage matching", dir);
    expect_contains(out, "--left0, --left1 in colour but --right0, --right1 in gray: all four are matched in gray");
    assert_true(out.find("in gray") < out.find("run: estimating"));
    expect_quality(out, "quality: ok");

    // viz names both sizes.
    write_image(dir / "small.png", cv::Mat(cv::Size(100, 50), CV_8UC3, cv::Scalar(0, 0, 0)));
    r = test::run_cli("viz --disp " + q(k / "disp_occ_0/000000_10.png") + " --image " + q(dir / "small.png") +
                      " --out " + q(dir / "v.png"));
    assert_int_not_equal(r.code, 0);
    expect_contains(r.output, "--image is 100x50 but the --disp map is 640x192");
    io::write_disparity_png((dir / "small_gt.png").string(), DisparityMap(50, 100, 1.0f));
    r = test::run_cli("viz --disp " + q(k / "disp_occ_0/000000_10.png") + " --gt " + q(dir / "small_gt.png") +
                      " --out " + q(dir / "v.png"));
    assert_int_not_equal(r.code, 0);
    expect_contains(r.output, "--gt is 100x50 but --disp is 640x192");
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(synthetic_frames),
        cmocka_unit_test(kitti_frames),
        cmocka_unit_test(run_messages),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
