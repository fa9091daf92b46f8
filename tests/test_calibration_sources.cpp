// SPDX-License-Identifier: MIT
// io/rig.hpp and io/rectify.hpp: KITTI's S_rect_02, OpenCV stereo files (YAML without the
// %YAML line, XML, K1/K2 names), camera_info pairs, rigs that need rectifying (distortion,
// rotations; stereoRectify when R1 R2 P1 P2 are absent: a 3-D point then lands on one row in
// both rectified images), the image-size comparison, and bad files: each refused with a
// message naming the file, never a crash or a hang (a FIFO, a folder, a huge file).
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "io/calib.hpp"
#include "io/rectify.hpp"
#include "io/rig.hpp"
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

const cv::Matx33d kK(700, 0, 320, 0, 690, 240, 0, 0, 1);
constexpr double kBaseline = 0.25;

std::string mat(const char *name, int rows, int cols, const std::vector<double> &v) {
    std::string s = std::string(name) + ": !!opencv-matrix\n   rows: " + std::to_string(rows) +
                    "\n   cols: " + std::to_string(cols) + "\n   dt: d\n   data: [";
    for (size_t i = 0; i < v.size(); ++i) {
        char buf[40];
        std::snprintf(buf, sizeof buf, "%s%.17g", i ? ", " : " ", v[i]);
        s += buf;
    }
    return s + " ]\n";
}

std::vector<double> vals(const cv::Matx33d &m) { return {m.val, m.val + 9}; }

// An OpenCV stereo file of the pinhole pair kK / kBaseline; `extra` appended (or replacing a key
// by coming later is not allowed in YAML: callers build what they need).
std::string opencv_yaml(const std::vector<double> &d1, const cv::Matx33d &R, bool header, const std::string &extra = "") {
    std::string s = header ? "%YAML:1.0\n---\n" : "";
    s += "image_width: 640\nimage_height: 480\n";
    s += mat("M1", 3, 3, vals(kK)) + mat("D1", 1, static_cast<int>(d1.size()), d1) + mat("M2", 3, 3, vals(kK)) +
         mat("D2", 1, 5, {0, 0, 0, 0, 0}) + mat("R", 3, 3, vals(R)) + mat("T", 3, 1, {-kBaseline, 0, 0});
    return s + extra;
}

std::string camera_info(double tx, const std::string &model = "plumb_bob", const std::string &d = "[0, 0, 0, 0, 0]",
                        int width = 640) {
    char p[200];
    std::snprintf(p, sizeof p, "[700, 0, 320, %.17g, 0, 690, 240, 0, 0, 0, 1, 0]", tx);
    return "image_width: " + std::to_string(width) +
           "\nimage_height: 480\ncamera_name: cam\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [700, 0, 320, 0, "
           "690, 240, 0, 0, 1]\ndistortion_model: " +
           model + "\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: " + d +
           "\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nprojection_matrix:\n  "
           "rows: 3\n  cols: 4\n  data: " +
           p + "\n";
}

void expect_camera(const io::Rig &rig) {
    const StereoCamera &c = rig.rect.camera;
    assert_true(std::abs(c.fx - 700) < 1e-9 && std::abs(c.fy - 690) < 1e-9 && std::abs(c.cx - 320) < 1e-9 &&
                std::abs(c.cy - 240) < 1e-9 && std::abs(c.baseline - kBaseline) < 1e-12);
    assert_true(rig.rect.image_size == cv::Size(640, 480));
}

fs::path write(const fs::path &dir, const std::string &name, const std::string &text) {
    std::ofstream(dir / name) << text;
    return dir / name;
}

void test_kitti_image_size(void **) {
    const std::string base = "R_rect_00: 1 0 0 0 1 0 0 0 1\nP_rect_02: 700 0 320 0 0 690 240 0 0 0 1 0\n"
                             "P_rect_03: 700 0 320 -175 0 690 240 0 0 0 1 0\n";
    assert_true(io::parse_calib_cam_to_cam(base, "k").image_size.empty());
    const io::CamToCamCalib c = io::parse_calib_cam_to_cam(base + "S_rect_02: 1.242000e+03 3.750000e+02\n", "k");
    assert_true(c.image_size == cv::Size(1242, 375));
    for (const char *bad : {"S_rect_02: 1242.5 375\n", "S_rect_02: 0 375\n", "S_rect_02: 1242\n", "S_rect_02: 99999 375\n"}) {
        const std::string m = test::error_message_of([&] { io::parse_calib_cam_to_cam(base + bad, "k.txt"); });
        assert_non_null(strstr(m.c_str(), "k.txt"));
    }
    // Written and read back.
    const fs::path dir = test::scratch_dir("calibration_sources_kitti");
    io::write_calib_cam_to_cam((dir / "c.txt").string(), c);
    assert_true(io::read_rig((dir / "c.txt").string()).rect.image_size == cv::Size(1242, 375));
}

void test_rectified_sources_agree(void **) {
    const fs::path dir = test::scratch_dir("calibration_sources_agree");
    const std::vector<double> no_d = {0, 0, 0, 0, 0};
    for (bool header : {true, false}) {
        const io::Rig r = io::read_rig(write(dir, "s.yml", opencv_yaml(no_d, cv::Matx33d::eye(), header)).string());
        expect_camera(r);
        assert_false(r.rectify);
    }
    // K1 / K2 instead of M1 / M2, and the XML that cv::FileStorage writes.
    std::string k_names = opencv_yaml(no_d, cv::Matx33d::eye(), true);
    k_names.replace(k_names.find("M1:"), 3, "K1:");
    k_names.replace(k_names.find("M2:"), 3, "K2:");
    expect_camera(io::read_rig(write(dir, "k.yml", k_names).string()));
    {
        cv::FileStorage fs((dir / "s.xml").string(), cv::FileStorage::WRITE);
        fs << "M1" << cv::Mat(kK) << "D1" << cv::Mat::zeros(1, 5, CV_64F) << "M2" << cv::Mat(kK) << "D2"
           << cv::Mat::zeros(1, 5, CV_64F) << "R" << cv::Mat::eye(3, 3, CV_64F) << "T"
           << cv::Mat(cv::Matx31d(-kBaseline, 0, 0)) << "imageSize" << cv::Size(640, 480);
    }
    expect_camera(io::read_rig((dir / "s.xml").string()));
    const fs::path l = write(dir, "left.yaml", camera_info(0)), r = write(dir, "right.yaml", camera_info(-700 * kBaseline));
    const io::Rig ci = io::read_rig(l.string() + "," + r.string());
    expect_camera(ci);
    assert_false(ci.rectify);
    assert_false(io::rig_from_pinhole({700, 690, 320, 240, kBaseline}).rectify);
}

// A 3-D point seen by the raw cameras lands on the same row of both rectified images.
void expect_rows_aligned(const io::Rig &rig, const cv::Matx33d &R, const cv::Vec3d &T) {
    assert_true(rig.rectify);
    for (const cv::Point3d X : {cv::Point3d(-2, -1, 8), cv::Point3d(3, 1.5, 12), cv::Point3d(0.5, -0.3, 25)}) {
        std::vector<cv::Point2d> pl, pr, ql, qr;
        cv::projectPoints(std::vector<cv::Point3d>{X}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(rig.left.K),
                          cv::Mat(rig.left.D), pl);
        cv::Vec3d rvec;
        cv::Rodrigues(cv::Mat(R), rvec);
        cv::projectPoints(std::vector<cv::Point3d>{X}, rvec, T, cv::Mat(rig.right.K), cv::Mat(rig.right.D), pr);
        cv::undistortPoints(pl, ql, cv::Mat(rig.left.K), cv::Mat(rig.left.D), cv::Mat(rig.left.R), cv::Mat(rig.left.P));
        cv::undistortPoints(pr, qr, cv::Mat(rig.right.K), cv::Mat(rig.right.D), cv::Mat(rig.right.R),
                            cv::Mat(rig.right.P));
        assert_true(std::abs(ql[0].y - qr[0].y) < 0.05);
        assert_true(ql[0].x > qr[0].x);  // positive disparity
    }
}

void test_raw_rigs(void **) {
    const fs::path dir = test::scratch_dir("calibration_sources_raw");
    // Distortion alone: rectify, with the given rotations (identity) and a stereoRectify camera.
    const io::Rig d = io::read_rig(
        write(dir, "d.yml", opencv_yaml({-0.3, 0.1, 0.001, 0.002, 0}, cv::Matx33d::eye(), true)).string());
    expect_rows_aligned(d, cv::Matx33d::eye(), {-kBaseline, 0, 0});
    // A rotated right camera without R1 R2 P1 P2: cv::stereoRectify.
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(0.01, -0.02, 0.005), R);
    const io::Rig r = io::read_rig(write(dir, "r.yml", opencv_yaml({0, 0, 0, 0, 0}, R, false)).string());
    expect_rows_aligned(r, R, {-kBaseline, 0, 0});
    // 8 coefficients, and 14 with zero thin-prism / tilt terms.
    const std::vector<double> d8 = {-0.3, 0.1, 0, 0, 0.01, 0.001, 0.002, 0.003};
    expect_rows_aligned(io::read_rig(write(dir, "d8.yml", opencv_yaml(d8, cv::Matx33d::eye(), true)).string()),
                        cv::Matx33d::eye(), {-kBaseline, 0, 0});
    std::vector<double> d14 = d8;
    d14.resize(14, 0.0);
    assert_true(io::read_rig(write(dir, "d14.yml", opencv_yaml(d14, cv::Matx33d::eye(), true)).string()).rectify);
    // camera_info with distortion: rectify; the rectifier keeps the size and blackens nothing
    // in the middle.
    const fs::path l = write(dir, "l.yaml", camera_info(0, "plumb_bob", "[-0.2, 0.05, 0, 0, 0]"));
    const fs::path rr = write(dir, "r.yaml", camera_info(-700 * kBaseline));
    const io::Rig ci = io::read_rig(l.string() + "," + rr.string());
    assert_true(ci.rectify);
    const io::Rectifier rect(ci, {640, 480});
    cv::Mat left(480, 640, CV_8UC3, cv::Scalar(200, 100, 50)), right(480, 640, CV_8UC1, cv::Scalar(77));
    cv::Mat lo, ro;
    rect.apply(left, right, lo, ro);
    assert_true(lo.size() == left.size() && lo.type() == CV_8UC3 && lo.at<cv::Vec3b>(240, 320) == cv::Vec3b(200, 100, 50));
    assert_true(ro.at<uchar>(240, 320) == 77);
    rect.apply(left, right, left, right);  // in place
    assert_true(left.at<cv::Vec3b>(240, 320) == cv::Vec3b(200, 100, 50));
    test::expect_error([&] { rect.apply(cv::Mat(10, 10, CV_8UC1), cv::Mat(10, 10, CV_8UC1), lo, ro); },
                       ErrorCode::SizeMismatch);
}

void test_image_size_mismatch(void **) {
    assert_string_equal(io::image_size_mismatch({}, {640, 480}).c_str(), "");
    assert_string_equal(io::image_size_mismatch({640, 480}, {640, 480}).c_str(), "");
    const std::string m = io::image_size_mismatch({1242, 375}, {640, 480});
    assert_non_null(strstr(m.c_str(), "640x480"));
    assert_non_null(strstr(m.c_str(), "1242x375"));
}

void expect_refused(const std::string &spec, const std::string &path_in_message, const char *why) {
    const std::string m = test::error_message_of([&] { io::read_rig(spec); });
    if (m.find(path_in_message) == std::string::npos || m.find(why) == std::string::npos)
        fail_msg("'%s' for %s: expected the file and \"%s\"", m.c_str(), spec.c_str(), why);
}

void test_bad_files(void **) {
    const fs::path dir = test::scratch_dir("calibration_sources_bad");
    const std::vector<double> no_d = {0, 0, 0, 0, 0};
    const std::string good = opencv_yaml(no_d, cv::Matx33d::eye(), true);
    auto refuse = [&](const std::string &name, const std::string &text, const char *why) {
        const fs::path p = write(dir, name, text);
        expect_refused(p.string(), p.string(), why);
    };
    refuse("malformed.yml", "%YAML:1.0\nM1: [1, 2\n  : : [[", "OpenCV can read");
    refuse("nan.yml", [&] {
        std::string s = good;
        s.replace(s.find("721") == std::string::npos ? s.find("700") : s.find("721"), 3, ".nan");
        return s;
    }(), "not finite");
    refuse("string.yml", "%YAML:1.0\nM1: [a, b, c, d, e, f, g, h, i]\n", "not a number");
    refuse("missing.yml", "%YAML:1.0\n" + mat("M1", 3, 3, vals(kK)) + mat("M2", 3, 3, vals(kK)), "missing key");
    refuse("count.yml", "%YAML:1.0\n" + mat("M1", 2, 2, {1, 2, 3, 4}) + mat("M2", 3, 3, vals(kK)), "expected 3x3");
    refuse("rows.yml", "%YAML:1.0\nM1: !!opencv-matrix\n   rows: 100000\n   cols: 100000\n   dt: d\n   data: [1, 2]\n",
           "rows x cols");
    refuse("d3.yml", opencv_yaml({0.1, 0.2, 0.3}, cv::Matx33d::eye(), true), "coefficients");
    refuse("tilt.yml",
           opencv_yaml({0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.1, 0}, cv::Matx33d::eye(), true), "not supported");
    refuse("partial.yml", good + mat("R1", 3, 3, vals(cv::Matx33d::eye())), "come together");
    refuse("nosize.yml", [&] {
        cv::Matx33d R;
        cv::Rodrigues(cv::Vec3d(0.01, 0, 0), R);
        std::string s = opencv_yaml(no_d, R, true);
        s.erase(s.find("image_width"), std::string("image_width: 640\nimage_height: 480\n").size());
        return s;
    }(), "image size");
    refuse("notrot.yml", opencv_yaml(no_d, cv::Matx33d(2, 0, 0, 0, 1, 0, 0, 0, 1), true), "not a rotation");
    refuse("left_of.yml", [&] {
        std::string s = good;
        s.replace(s.find("-0.25"), 5, "0.25");
        return s;
    }(), "baseline");
    refuse("unknown.txt", "hello: world\n", "not a KITTI");
    refuse("one_info.yaml", camera_info(0), "camera_info");
    refuse("empty.yml", "", "not a KITTI");
    refuse("nul.yml", std::string("%YAML:1.0\nM1: [1\0, 2]\n", 20), "NUL");
    // OpenCV's XML parser crashes on these (found by fuzz_io_calibration).
    refuse("header.xml", "<?xml vzr=", "truncated");
    refuse("attribute.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n<M1 type_id= \n", "truncated");
    // camera_info pairs.
    const fs::path l = write(dir, "l.yaml", camera_info(0)), r = write(dir, "r.yaml", camera_info(-175));
    const fs::path fish = write(dir, "fish.yaml", camera_info(0, "equidistant", "[0.1, 0, 0, 0]"));
    expect_refused(fish.string() + "," + r.string(), fish.string(), "equidistant");
    const fs::path wide = write(dir, "wide.yaml", camera_info(-175, "plumb_bob", "[0, 0, 0, 0, 0]", 800));
    expect_refused(l.string() + "," + wide.string(), wide.string(), "different image sizes");
    const fs::path up = write(dir, "up.yaml", [&] {
        std::string s = camera_info(-175);
        s.replace(s.find("690, 240, 0, 0, 0, 1, 0]"), 24, "690, 240, 9, 0, 0, 1, 0]");
        return s;
    }());
    expect_refused(l.string() + "," + up.string(), l.string(), "vertical");
    expect_refused(l.string() + ",", l.string(), "LEFT,RIGHT");
    expect_refused(l.string() + "," + (dir / "absent.yaml").string(), "absent.yaml", "cannot open");
    // Not regular files, too large: refused before reading.
    const fs::path fifo = dir / "fifo.yml";
    assert_int_equal(mkfifo(fifo.c_str(), 0600), 0);
    expect_refused(fifo.string(), fifo.string(), "not a regular file");
    expect_refused(dir.string(), dir.string(), "not a regular file");
    {
        std::ofstream big(dir / "big.yml");
        big << "%YAML:1.0\n# " << std::string(io::kMaxCalibrationFileBytes, 'x') << "\n";
    }
    expect_refused((dir / "big.yml").string(), (dir / "big.yml").string(), "bytes");
    test::expect_error([] { io::read_rig(""); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { io::read_rig((dir / "absent.yml").string()); }, ErrorCode::Io);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kitti_image_size), cmocka_unit_test(test_rectified_sources_agree),
        cmocka_unit_test(test_raw_rigs),         cmocka_unit_test(test_image_size_mismatch),
        cmocka_unit_test(test_bad_files),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
