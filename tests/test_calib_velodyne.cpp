// SPDX-License-Identifier: MIT
// KITTI calibration parsers / writer (io/calib) and the Velodyne .bin reader (io/velodyne):
// the real files of the shared frames, malformed text, and bad binary sizes.
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/velodyne.hpp"
#include "io/velo_to_left.hpp"
#include "lidar/projection.hpp"
// cmocka.h defines fail(), which breaks <ios>, and its 1.1.5 header lacks extern "C": include
// it last, wrapped (test_support.hpp's own include is then a no-op).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;
using test::throws_code;
namespace fs = std::filesystem;

namespace {


const char *kCamToCam =
    "calib_time: 09-Jan-2012 13:57:47\n"
    "corner_dist: 9.950000e-02\n"
    "R_rect_00: 1 0 0 0 1 0 0 0 1\n"
    "P_rect_02: 700 0 600 40 0 710 170 0.2 0 0 1 0.003\n"
    "P_rect_03: 700 0 600 -338 0 710 170 2.2 0 0 1 0.003\n";

const char *kVeloToCam =
    "calib_time: 15-Mar-2012 11:37:16\n"
    "R: 0 -1 0 0 0 -1 1 0 0\n"
    "T: -0.004 -0.076 -0.27\n"
    "delta_f: 0 0\n";

std::string replace(std::string s, const std::string &from, const std::string &to) {
    const auto at = s.find(from);
    if (at != std::string::npos) s.replace(at, from.size(), to);
    return s;
}

bool cam_format_error(const std::string &text) {
    return throws_code(ErrorCode::Format, [&] { io::parse_calib_cam_to_cam(text, "test"); });
}
bool velo_format_error(const std::string &text) {
    return throws_code(ErrorCode::Format, [&] { io::parse_calib_velo_to_cam(text, "test"); });
}

void test_parse_cam_to_cam_text(void **) {
    const io::CamToCamCalib c = io::parse_calib_cam_to_cam(kCamToCam, "test");
    assert_true(c.camera.fx == 700 && c.camera.fy == 710 && c.camera.cx == 600 && c.camera.cy == 170);
    assert_true(std::fabs(c.camera.baseline - 378.0 / 700.0) < 1e-15);
    assert_true(c.P_rect_02(1, 3) == 0.2 && c.P_rect_03(2, 3) == 0.003 && c.R_rect_00(2, 2) == 1);
    // CRLF line ends and blank lines are fine.
    assert_true(io::parse_calib_cam_to_cam(replace(std::string(kCamToCam), "\n", "\r\n\n"), "t").camera.fx == 700);

    const std::string good = kCamToCam;
    assert_true(cam_format_error(replace(good, "P_rect_03: 700 0 600 -338 0 710 170 2.2 0 0 1 0.003\n", "")));
    assert_true(cam_format_error(replace(good, "R_rect_00", "R_rect_01")));                  // missing key
    assert_true(cam_format_error(replace(good, " 0.2 0 0 1 0.003", " 0.2 0 0 1")));          // 11 values
    assert_true(cam_format_error(replace(good, "0 0 1 0.003\nP_rect_03", "0 0 1 0.003 5\nP_rect_03")));  // 13
    assert_true(cam_format_error(replace(good, "1 0 0 0 1 0 0 0 1", "1 0 0 0 1 0 0 0 nan")));
    assert_true(cam_format_error(replace(good, "1 0 0 0 1 0 0 0 1", "1 0 0 0 1 0 0 0 inf")));
    assert_true(cam_format_error(replace(good, "1 0 0 0 1 0 0 0 1", "1 0 0 0 1 0 0 0 1e999")));
    assert_true(cam_format_error(replace(good, "700 0 600 40", "700 0 six 40")));
    assert_true(cam_format_error(replace(good, "700 0 600 40", "700x 0 600 40")));
    assert_true(cam_format_error(good + "P_rect_02: 1 0 0 0 0 1 0 0 0 0 1 0\n"));           // duplicate
    assert_true(cam_format_error(good + "no colon on this line\n"));
    assert_true(cam_format_error(replace(good, "700 0 600 40", "-700 0 600 40")));           // fx <= 0
    assert_true(cam_format_error(replace(good, "-338", "338")));                               // baseline <= 0
    assert_true(cam_format_error(""));
}

void test_parse_velo_to_cam_text(void **) {
    const cv::Matx44d M = io::parse_calib_velo_to_cam(kVeloToCam, "test");
    assert_true(M(0, 1) == -1 && M(1, 2) == -1 && M(2, 0) == 1 && M(2, 3) == -0.27);
    assert_true(M(3, 0) == 0 && M(3, 1) == 0 && M(3, 2) == 0 && M(3, 3) == 1);
    // A velodyne point 10 m ahead ends up 10 m in front of the camera (z), up to T.
    const cv::Vec4d p = M * cv::Vec4d(10, 0, 0, 1);
    assert_true(std::fabs(p[2] - (10 - 0.27)) < 1e-12);

    const std::string good = kVeloToCam;
    assert_true(velo_format_error(replace(good, "T: -0.004 -0.076 -0.27\n", "")));
    assert_true(velo_format_error(replace(good, "-0.076 -0.27", "-0.076")));
    assert_true(velo_format_error(replace(good, "R: 0 -1 0 0 0 -1 1 0 0", "R: 0 -1 0 0 0 -1 1 0")));
    assert_true(velo_format_error(replace(good, "-0.27", "NaN")));
    assert_true(velo_format_error(replace(good, "R: 0 -1 0 0 0 -1 1 0 0", "R: 2 0 0 0 1 0 0 0 1")));   // not a rotation
    assert_true(velo_format_error(replace(good, "R: 0 -1 0 0 0 -1 1 0 0", "R: -1 0 0 0 1 0 0 0 1")));  // reflection
    assert_true(velo_format_error(good + "T: 0 0 0\n"));
}

void test_missing_files(void **) {
    const fs::path dir = test::scratch_dir("calib_missing");
    assert_true(throws_code(ErrorCode::Io, [&] { io::read_calib_cam_to_cam((dir / "none.txt").string()); }));
    assert_true(throws_code(ErrorCode::Io, [&] { io::read_calib_velo_to_cam((dir / "none.txt").string()); }));
    assert_true(throws_code(ErrorCode::Io, [&] { io::read_velodyne_bin((dir / "none.bin").string()); }));
}

void test_writer_round_trip(void **) {
    const fs::path dir = test::scratch_dir("calib_writer");
    StereoCamera cam;
    cam.fx = 721.5377;
    cam.fy = 721.5377;
    cam.cx = 609.5593;
    cam.cy = 172.854;
    cam.baseline = 0.5327254;
    const io::CamToCamCalib c = io::calib_from_camera(cam);
    assert_true(c.P_rect_02(0, 3) == 0 && c.P_rect_03(0, 3) == -cam.fx * cam.baseline);
    assert_true(c.P_rect_03(0, 0) == cam.fx && c.P_rect_03(1, 2) == cam.cy && c.R_rect_00 == cv::Matx33d::eye());

    const fs::path p = dir / "calib_cam_to_cam" / "000000.txt";  // parent folder is created
    io::write_calib_cam_to_cam(p.string(), c);
    const io::CamToCamCalib back = io::read_calib_cam_to_cam(p.string());
    assert_true(back.P_rect_02 == c.P_rect_02 && back.P_rect_03 == c.P_rect_03 && back.R_rect_00 == c.R_rect_00);
    assert_true(back.camera.fx == cam.fx && back.camera.fy == cam.fy && back.camera.cx == cam.cx &&
                back.camera.cy == cam.cy);
    assert_true(std::fabs(back.camera.baseline - cam.baseline) < 1e-15);

    io::CamToCamCalib bad = c;
    bad.P_rect_03(1, 1) = std::numeric_limits<double>::quiet_NaN();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { io::write_calib_cam_to_cam((dir / "x.txt").string(), bad); }));
    // A file where a folder is needed.
    assert_true(throws_code(ErrorCode::Io, [&] { io::write_calib_cam_to_cam((p / "x.txt").string(), c); }));
    StereoCamera none;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { io::calib_from_camera(none); }));
    StereoCamera inf_cam = cam;
    inf_cam.cx = std::numeric_limits<double>::infinity();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { io::calib_from_camera(inf_cam); }));
}

void write_floats(const fs::path &p, const std::vector<float> &v, std::size_t extra_bytes = 0) {
    std::ofstream out(p, std::ios::binary);
    out.write(reinterpret_cast<const char *>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(float)));
    for (std::size_t i = 0; i < extra_bytes; ++i) out.put('\0');
}

void test_velodyne_bin(void **) {
    const fs::path dir = test::scratch_dir("velodyne_bin");
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();

    write_floats(dir / "ok.bin", {1, 2, 3, 0.5f, nan, 0, 0, 0, 4, 5, 6, inf, -7, 8, 9, 0.25f});
    const io::VelodyneScan s = io::read_velodyne_bin((dir / "ok.bin").string());
    // A NaN position drops its record; an infinite reflectance only reads as 0.
    assert_int_equal(s.points.size(), 3);
    assert_int_equal(s.dropped_nonfinite, 1);
    assert_int_equal(s.nonfinite_reflectance, 1);
    assert_true(s.points[0].x == 1 && s.points[0].y == 2 && s.points[0].z == 3 && s.points[0].reflectance == 0.5f);
    assert_true(s.points[1].x == 4 && s.points[1].y == 5 && s.points[1].z == 6 && s.points[1].reflectance == 0);
    assert_true(s.points[2].x == -7 && s.points[2].reflectance == 0.25f);

    write_floats(dir / "empty.bin", {});
    write_floats(dir / "odd.bin", {1, 2, 3, 4}, 1);          // 17 bytes
    write_floats(dir / "three.bin", {1, 2, 3});              // 12 bytes
    write_floats(dir / "allnan.bin", {nan, 1, 2, 3, 4, nan, 5, 6});
    for (const char *name : {"empty.bin", "odd.bin", "three.bin", "allnan.bin"})
        assert_true(throws_code(ErrorCode::Format, [&] { io::read_velodyne_bin((dir / name).string()); }));
}

// A rig like KITTI's (camera 2 offset from camera 0, a small rectifying rotation, a LiDAR
// mounted above and behind): projecting through the composed Velodyne -> left rectified
// transform with the offset-free K gives exactly the devkit chain's pixels and disparities.
void test_velo_to_left_rect(void **) {
    io::CamToCamCalib c;
    c.P_rect_02 = {700, 0, 600, 45.0, 0, 710, 180, 0.2, 0, 0, 1, 0.003};
    c.P_rect_03 = {700, 0, 600, -330.0, 0, 710, 180, 2.3, 0, 0, 1, 0.003};
    c.camera = {700, 710, 600, 180, (45.0 + 330.0) / 700};
    const double a = 0.01;  // rotation about y
    c.R_rect_00 = {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)};
    // Velodyne (x forward, y left, z up) -> camera 0 (x right, y down, z forward), offset.
    const cv::Matx44d velo(0, -1, 0, 0.01, 0, 0, -1, -0.08, 1, 0, 0, -0.27, 0, 0, 0, 1);
    const cv::Matx44d T = io::velo_to_left_rect(c, velo);
    assert_true(T(3, 0) == 0 && T(3, 1) == 0 && T(3, 2) == 0 && T(3, 3) == 1);

    std::vector<io::VelodynePoint> scan;
    std::vector<cv::Point3d> left;
    for (int i = 0; i < 400; ++i) {
        const io::VelodynePoint q{5.0f + 0.1f * i, -8.0f + 0.04f * i, -1.5f + 0.006f * i, 0};
        scan.push_back(q);
        const cv::Vec4d x = T * cv::Vec4d(q.x, q.y, q.z, 1);
        left.emplace_back(x[0], x[1], x[2]);
    }
    const cv::Size image(1242, 375);
    const SparseLidar devkit = lidar::project_to_left(scan, c, velo, image);
    const SparseLidar composed = lidar::project_to_left(left, io::calib_from_camera(c.camera), image);
    assert_true(devkit.points.size() > 100);
    assert_int_equal(devkit.points.size(), composed.points.size());
    for (size_t i = 0; i < devkit.points.size(); ++i) {
        assert_true(devkit.points[i].x == composed.points[i].x && devkit.points[i].y == composed.points[i].y);
        assert_true(std::fabs(devkit.points[i].disparity - composed.points[i].disparity) < 1e-4);
    }
    io::CamToCamCalib bad = c;
    bad.P_rect_02(2, 2) = 0.5;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { io::velo_to_left_rect(bad, velo); }));
    bad = c;
    bad.R_rect_00(0, 0) = std::numeric_limits<double>::quiet_NaN();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { io::velo_to_left_rect(bad, velo); }));
}

void test_real_files(void **) {
    const std::string root = test::kitti_dir();
    if (root.empty()) {
        std::printf("KITTI frames not available (LIDARFLOW_KITTI_DIR): skipped\n");
        skip();
    }
    const io::KittiLayout L{root};
    for (const std::string &id : L.frame_ids()) {
        const io::CamToCamCalib c = io::read_calib_cam_to_cam(L.calib_cam_to_cam(id));
        assert_true(std::fabs(c.camera.fx - 721.5377) < 1e-4 && std::fabs(c.camera.fy - 721.5377) < 1e-4);
        assert_true(std::fabs(c.camera.cx - 609.5593) < 1e-4 && std::fabs(c.camera.cy - 172.854) < 1e-4);
        // (44.85728 + 339.5242) / 721.5377 from the file's P_rect_02 / P_rect_03.
        assert_true(std::fabs(c.camera.baseline - 0.532725) < 1e-5);
        assert_true(std::fabs(c.R_rect_00(0, 1) - 9.837760e-03) < 1e-12);
        assert_true(std::fabs(c.P_rect_02(2, 3) - 2.745884e-03) < 1e-12);
        std::printf("%s: fx %.4f  baseline %.6f m\n", id.c_str(), c.camera.fx, c.camera.baseline);

        const cv::Matx44d M = io::read_calib_velo_to_cam(L.calib_velo_to_cam(id));
        assert_true(std::fabs(M(0, 0) - 7.533745e-03) < 1e-12 && std::fabs(M(2, 3) + 2.717806e-01) < 1e-12);
        assert_true(M(3, 3) == 1 && M(3, 0) == 0);

        const io::VelodyneScan s = io::read_velodyne_bin(L.velodyne(id));
        assert_int_equal((s.points.size() + s.dropped_nonfinite) * 16, fs::file_size(L.velodyne(id)));
        assert_true(s.points.size() > 100000);
        std::printf("%s: %zu Velodyne points, %zu non-finite dropped\n", id.c_str(), s.points.size(),
                    s.dropped_nonfinite);
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_cam_to_cam_text),
        cmocka_unit_test(test_parse_velo_to_cam_text),
        cmocka_unit_test(test_missing_files),
        cmocka_unit_test(test_writer_round_trip),
        cmocka_unit_test(test_velodyne_bin),
        cmocka_unit_test(test_velo_to_left_rect),
        cmocka_unit_test(test_real_files),
    };
    return cmocka_run_group_tests_name("calib_velodyne", tests, nullptr, nullptr);
}
