// SPDX-License-Identifier: MIT
// Result files other than KITTI PNGs (io/result_formats) and the point cloud (io/point_cloud):
// every format written and read back equals the field, holes included; the bytes are what the
// formats specify (PFM bottom-up little-endian, .npy header aligned); broken files are Format
// errors; the 3-D points follow the triangulation of lf_get_points3d.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/error.hpp"
#include "core/points3d.hpp"
#include "io/kitti_submission.hpp"
#include "io/point_cloud.hpp"
#include "io/result_formats.hpp"
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

// A 7x5 field with varied values and holes (valid = 0) at fixed pixels; one valid pixel has
// d1 = 0 (no 3-D point: the point is at infinity at t1).
SceneFlowField sample_field() {
    SceneFlowField f = SceneFlowField::zeros(7, 5);
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 7; ++x) {
            f.u(y, x) = 0.37f * x - 1.25f * y;
            f.v(y, x) = -0.5f + 0.11f * x * y;
            f.d0(y, x) = 10.0f + x + 0.25f * y;
            f.d1(y, x) = 9.5f + x - 0.125f * y;
            f.valid(y, x) = (x + 2 * y) % 5 != 0;
            f.confidence(y, x) = 0.1f * static_cast<float>(x + y) + 0.05f;
        }
    f.d1(4, 6) = 0.0f;
    f.valid(4, 6) = 1;
    return f;
}

std::string slurp(const fs::path &p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void expect_disparity(const cv::Mat &m, const cv::Mat1f &d, const cv::Mat1b &valid) {
    assert_int_equal(m.type(), CV_32FC1);
    assert_true(m.size() == d.size());
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x) {
            const float got = m.at<float>(y, x);
            if (valid(y, x))
                assert_true(got == d(y, x));
            else
                assert_true(std::isnan(got));
        }
}

void expect_flow(const cv::Mat &m, const SceneFlowField &f) {
    assert_int_equal(m.type(), CV_32FC3);
    assert_true(m.size() == f.u.size());
    for (int y = 0; y < f.u.rows; ++y)
        for (int x = 0; x < f.u.cols; ++x) {
            const cv::Vec3f p = m.at<cv::Vec3f>(y, x);
            if (f.valid(y, x)) {
                assert_true(p[0] == f.u(y, x) && p[1] == f.v(y, x) && p[2] == 1.0f);
            } else {
                assert_true(std::isnan(p[0]) && std::isnan(p[1]) && p[2] == 0.0f);
            }
        }
}

// .npy flow: (H, W, 2) u, v with NaN holes, validity in valid/ID_10.npy (uint8).
void expect_flow_npy(const cv::Mat &m, const cv::Mat &valid, const SceneFlowField &f) {
    assert_int_equal(m.type(), CV_32FC2);
    assert_int_equal(valid.type(), CV_8UC1);
    assert_true(m.size() == f.u.size() && valid.size() == f.u.size());
    for (int y = 0; y < f.u.rows; ++y)
        for (int x = 0; x < f.u.cols; ++x) {
            const cv::Vec2f p = m.at<cv::Vec2f>(y, x);
            assert_int_equal(valid.at<uint8_t>(y, x), f.valid(y, x) ? 1 : 0);
            if (f.valid(y, x))
                assert_true(p[0] == f.u(y, x) && p[1] == f.v(y, x));
            else
                assert_true(std::isnan(p[0]) && std::isnan(p[1]));
        }
}

void test_round_trips(void **) {
    const fs::path dir = test::scratch_dir("io_result_files");
    const SceneFlowField f = sample_field();
    for (io::ResultFormat fmt : {io::ResultFormat::Pfm, io::ResultFormat::Npy, io::ResultFormat::Flo}) {
        const std::vector<std::string> files = io::write_results(dir.string(), "000007", f, fmt);
        const bool npy = fmt == io::ResultFormat::Npy;
        assert_int_equal(files.size(), npy ? 5 : fmt == io::ResultFormat::Pfm ? 4 : 3);
        const auto read = [npy](const std::string &p) { return npy ? io::read_npy(p) : io::read_pfm(p); };
        assert_true(files[0] == (dir / "disp_0" / (npy ? "000007_10.npy" : "000007_10.pfm")).string());
        expect_disparity(read(files[0]), f.d0, f.valid);
        expect_disparity(read(files[1]), f.d1, f.valid);
        if (fmt == io::ResultFormat::Flo) {
            assert_true(files[2] == (dir / "flow" / "000007_10.flo").string());
            const FlowField back = io::read_flo(files[2]);
            for (int y = 0; y < f.u.rows; ++y)
                for (int x = 0; x < f.u.cols; ++x) {
                    assert_int_equal(back.valid(y, x), f.valid(y, x) ? 1 : 0);
                    if (f.valid(y, x)) assert_true(back.u(y, x) == f.u(y, x) && back.v(y, x) == f.v(y, x));
                }
        } else if (npy) {
            assert_true(files[3] == (dir / "valid" / "000007_10.npy").string());
            expect_flow_npy(read(files[2]), read(files[3]), f);
            test::expect_error([&] { io::read_flow_file(files[3]); }, ErrorCode::Format);
        } else {
            expect_flow(read(files[2]), f);
        }
        if (fmt != io::ResultFormat::Flo) {  // the confidence, 0 where the field is not valid
            assert_true(files.back() == (dir / "confidence" / (npy ? "000007_10.npy" : "000007_10.pfm")).string());
            const cv::Mat c = read(files.back());
            assert_int_equal(c.type(), CV_32FC1);
            for (int y = 0; y < f.u.rows; ++y)
                for (int x = 0; x < f.u.cols; ++x)
                    assert_true(c.at<float>(y, x) == (f.valid(y, x) ? f.confidence(y, x) : 0.0f));
        }
    }
    // The kitti format is the devkit layout.
    const std::vector<std::string> png = io::write_results(dir.string(), "000007", f, io::ResultFormat::Kitti);
    for (const std::string &p : png) assert_true(fs::exists(p) && p.size() > 4 && p.substr(p.size() - 4) == ".png");
}

void test_bytes_on_disk(void **) {
    const fs::path dir = test::scratch_dir("io_result_bytes");
    cv::Mat1f m(2, 3);
    for (int i = 0; i < 6; ++i) m(i / 3, i % 3) = static_cast<float>(i) + 0.5f;
    io::write_pfm((dir / "m.pfm").string(), m);
    const std::string pfm = slurp(dir / "m.pfm");
    const std::string header = "Pf\n3 2\n-1.0\n";
    assert_int_equal(pfm.size(), header.size() + 24);
    assert_true(pfm.compare(0, header.size(), header) == 0);
    // First stored row is the image's bottom row; values little-endian.
    float first;
    const unsigned char le[4] = {static_cast<unsigned char>(pfm[header.size()]),
                                 static_cast<unsigned char>(pfm[header.size() + 1]),
                                 static_cast<unsigned char>(pfm[header.size() + 2]),
                                 static_cast<unsigned char>(pfm[header.size() + 3])};
    const uint32_t bits = le[0] | le[1] << 8 | le[2] << 16 | static_cast<uint32_t>(le[3]) << 24;
    std::memcpy(&first, &bits, 4);
    assert_true(first == m(1, 0));

    io::write_npy((dir / "m.npy").string(), m);
    const std::string npy = slurp(dir / "m.npy");
    assert_true(npy.compare(0, 8, std::string("\x93NUMPY\x01\x00", 8)) == 0);
    const size_t hlen = static_cast<unsigned char>(npy[8]) | static_cast<size_t>(static_cast<unsigned char>(npy[9])) << 8;
    assert_int_equal((10 + hlen) % 64, 0);
    assert_int_equal(npy[10 + hlen - 1], '\n');
    assert_true(npy.find("'shape': (2, 3)") != std::string::npos);
    assert_int_equal(npy.size(), 10 + hlen + 24);
    const cv::Mat back = io::read_npy((dir / "m.npy").string());
    assert_int_equal(cv::norm(back, m, cv::NORM_INF), 0);

    // A big-endian PFM (positive scale) reads the same.
    std::string be = "Pf\n3 2\n1.0\n";
    for (int y = 1; y >= 0; --y)
        for (int x = 0; x < 3; ++x) {
            uint32_t u;
            std::memcpy(&u, &m(y, x), 4);
            for (int k = 3; k >= 0; --k) be.push_back(static_cast<char>((u >> (8 * k)) & 0xff));
        }
    std::ofstream(dir / "be.pfm", std::ios::binary) << be;
    assert_int_equal(cv::norm(io::read_pfm((dir / "be.pfm").string()), m, cv::NORM_INF), 0);
}

void test_broken_files(void **) {
    const fs::path dir = test::scratch_dir("io_result_broken");
    cv::Mat3f m(4, 4, cv::Vec3f(1, 2, 3));
    io::write_pfm((dir / "ok.pfm").string(), m);
    io::write_npy((dir / "ok.npy").string(), m);
    const std::string pfm = slurp(dir / "ok.pfm"), npy = slurp(dir / "ok.npy");
    std::ofstream(dir / "short.pfm", std::ios::binary) << pfm.substr(0, pfm.size() - 5);
    std::ofstream(dir / "short.npy", std::ios::binary) << npy.substr(0, npy.size() - 5);
    std::ofstream(dir / "magic.pfm", std::ios::binary) << "P6\n4 4\n255\n";
    std::ofstream(dir / "dims.pfm", std::ios::binary) << "PF\n-4 4\n-1.0\n";
    std::string f8 = npy;
    f8.replace(f8.find("<f4"), 3, "<f8");
    std::ofstream(dir / "f8.npy", std::ios::binary) << f8;
    std::ofstream(dir / "text.npy", std::ios::binary) << "hello";
    for (const char *name : {"short.pfm", "magic.pfm", "dims.pfm"})
        test::expect_error([&] { io::read_pfm((dir / name).string()); }, ErrorCode::Format);
    for (const char *name : {"short.npy", "f8.npy", "text.npy"})
        test::expect_error([&] { io::read_npy((dir / name).string()); }, ErrorCode::Format);
    test::expect_error([&] { io::read_pfm((dir / "none.pfm").string()); }, ErrorCode::Io);
    test::expect_error([&] { io::read_flo((dir / "none.flo").string()); }, ErrorCode::Io);
    test::expect_error([&] { io::read_flo((dir / "ok.npy").string()); }, ErrorCode::Format);
    test::expect_error([&] { io::write_pfm((dir / "x.pfm").string(), cv::Mat1b(2, 2)); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { io::parse_result_format("pmf"); }, ErrorCode::InvalidArgument);
    assert_true(io::parse_result_format("npy") == io::ResultFormat::Npy);
}

// Headers that announce more than the file holds, or sides beyond the limit, are Format errors
// found before anything is allocated (a 65536 x 65536 x 3 float map would be 48 GiB).
void test_headers_checked_before_allocation(void **) {
    const fs::path dir = test::scratch_dir("io_result_headers");
    std::ofstream(dir / "huge.pfm", std::ios::binary) << "PF\n65536 65536\n-1.0\n" << std::string(48, '\0');
    std::ofstream(dir / "wide.pfm", std::ios::binary) << "Pf\n20000 1\n-1.0\n" << std::string(80000, '\0');
    std::string npy = "{'descr': '<f4', 'fortran_order': False, 'shape': (65536, 65536, 3), }";
    npy.resize(117, ' ');
    npy.push_back('\n');
    std::ofstream(dir / "huge.npy", std::ios::binary)
        << std::string("\x93NUMPY\x01\x00\x76\x00", 10) << npy << std::string(48, '\0');
    for (const char *name : {"huge.pfm", "wide.pfm"})
        test::expect_error([&] { io::read_pfm((dir / name).string()); }, ErrorCode::Format);
    test::expect_error([&] { io::read_npy((dir / "huge.npy").string()); }, ErrorCode::Format);
    // .flo: tag, width, height (int32 little-endian), then u, v per pixel.
    auto flo = [&](const char *name, int32_t w, int32_t h, size_t payload) {
        std::string b = "PIEH";
        for (int32_t v : {w, h})
            for (int k = 0; k < 4; ++k) b.push_back(static_cast<char>((static_cast<uint32_t>(v) >> (8 * k)) & 0xff));
        b += std::string(payload, '\0');
        std::ofstream(dir / name, std::ios::binary) << b;
    };
    flo("huge.flo", 100000, 100000, 64);
    flo("negative.flo", -3, 2, 48);
    flo("short.flo", 3, 2, 47);
    flo("ok.flo", 3, 2, 48);
    for (const char *name : {"huge.flo", "negative.flo", "short.flo"})
        test::expect_error([&] { io::read_flo((dir / name).string()); }, ErrorCode::Format);
    const FlowField ok = io::read_flo((dir / "ok.flo").string());
    assert_true(ok.width() == 3 && ok.height() == 2 && cv::countNonZero(ok.valid) == 6);
}

// read_disparity_file / read_flow_file read every file write_results writes, by extension, and
// give the field back with the same holes.
void test_any_format_readers(void **) {
    const fs::path dir = test::scratch_dir("io_result_any");
    const SceneFlowField f = sample_field();
    for (io::ResultFormat fmt : {io::ResultFormat::Kitti, io::ResultFormat::Flo, io::ResultFormat::Pfm,
                                 io::ResultFormat::Npy}) {
        const std::vector<std::string> files = io::write_results(dir.string(), "000000", f, fmt);
        const DisparityMap d0 = io::read_disparity_file(files[0]);
        const FlowField fl = io::read_flow_file(files[2]);
        const double tol = fmt == io::ResultFormat::Kitti ? 1.0 / 64 + 1e-4 : 0.0;
        for (int y = 0; y < f.height(); ++y)
            for (int x = 0; x < f.width(); ++x) {
                const bool v = f.valid(y, x) != 0;
                assert_int_equal(disparity_valid(d0(y, x)), v);
                assert_int_equal(fl.valid(y, x), v);
                if (!v) continue;
                assert_true(std::fabs(d0(y, x) - f.d0(y, x)) <= tol);
                assert_true(std::fabs(fl.u(y, x) - f.u(y, x)) <= tol && std::fabs(fl.v(y, x) - f.v(y, x)) <= tol);
            }
    }
    // (H, W, 2) flow: NaN marks the holes.
    cv::Mat2f uv(2, 3, cv::Vec2f(1.5f, -2.0f));
    uv(1, 2) = cv::Vec2f(std::nanf(""), std::nanf(""));
    {
        // write_npy takes 1 or 3 channels: build the two-channel file from a 3-channel one.
        cv::Mat3f uvw(2, 3, cv::Vec3f(1.5f, -2.0f, 0.0f));
        io::write_npy((dir / "uv3.npy").string(), uvw);
        std::string b = slurp(dir / "uv3.npy");
        b.replace(b.find("(2, 3, 3)"), 9, "(2, 3, 2)");
        const size_t data = b.size() - 2 * 3 * 3 * 4;
        std::string payload;
        for (int i = 0; i < 6; ++i) {
            const cv::Vec2f p = uv(i / 3, i % 3);
            payload.append(reinterpret_cast<const char *>(&p[0]), 4).append(reinterpret_cast<const char *>(&p[1]), 4);
        }
        b = b.substr(0, data) + payload;
        std::ofstream(dir / "uv2.npy", std::ios::binary) << b;
    }
    const FlowField two = io::read_flow_file((dir / "uv2.npy").string());
    assert_int_equal(cv::countNonZero(two.valid), 5);
    assert_true(two.u(0, 0) == 1.5f && two.v(1, 1) == -2.0f && two.valid(1, 2) == 0);
    // Wrong kinds and unknown extensions are Format errors naming what is read.
    const std::string flow_npy = (dir / "flow" / "000000_10.npy").string();
    test::expect_error([&] { io::read_disparity_file(flow_npy); }, ErrorCode::Format);
    test::expect_error([&] { io::read_flow_file((dir / "disp_0" / "000000_10.npy").string()); }, ErrorCode::Format);
    test::expect_error([&] { io::read_flow_file((dir / "x.tiff").string()); }, ErrorCode::Format);
}

void test_point_cloud(void **) {
    const fs::path dir = test::scratch_dir("io_point_cloud");
    const SceneFlowField f = sample_field();
    const StereoCamera cam{700.0, 690.0, 3.2, 2.1, 0.54};
    cv::Mat image(5, 7, CV_8UC3);
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 7; ++x) image.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 30, y * 50, 200);  // BGR
    const std::vector<io::CloudPoint> pts = io::scene_points(f, cam, image);
    int expected = 0;
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 7; ++x) expected += f.valid(y, x) && f.d0(y, x) > 0 && f.d1(y, x) > 0;
    assert_int_equal(pts.size(), expected);
    assert_true(expected < cv::countNonZero(f.valid));  // the d1 = 0 pixel is left out
    // Row-major order: the first point is the first valid pixel, (1, 0).
    const double z = cam.fx * cam.baseline / f.d0(0, 1);
    assert_true(std::fabs(pts[0].position[2] - z) < 1e-4 * z);
    assert_true(std::fabs(pts[0].position[0] - (1 - cam.cx) * z / cam.fx) < 1e-5);
    ScenePoint3 q;
    assert_true(triangulate_scene_flow(cam, 1, 0, f.u(0, 1), f.v(0, 1), f.d0(0, 1), f.d1(0, 1), &q));
    assert_true(std::fabs(pts[0].motion[2] - q.dz) < 1e-5 && std::fabs(pts[0].motion[0] - q.dx) < 1e-5);
    assert_true(pts[0].rgb == cv::Vec3b(200, 0, 30));  // red green blue

    io::write_ply((dir / "c.ply").string(), pts);
    const std::vector<io::CloudPoint> back = io::read_ply((dir / "c.ply").string());
    assert_int_equal(back.size(), pts.size());
    for (size_t i = 0; i < pts.size(); ++i) {
        assert_true(back[i].position == pts[i].position && back[i].motion == pts[i].motion);
        assert_true(back[i].rgb == pts[i].rgb);
    }
    const std::string ply = slurp(dir / "c.ply");
    std::ofstream(dir / "short.ply", std::ios::binary) << ply.substr(0, ply.size() - 1);
    test::expect_error([&] { io::read_ply((dir / "short.ply").string()); }, ErrorCode::Format);
    // A vertex count whose size (27 bytes a point) wraps modulo 2^64 to the body's 1 byte: 27 is
    // odd, so 9564978408590137875 * 27 = 1 (mod 2^64). A count error, not an allocation failure.
    const std::string head = ply.substr(0, ply.find("end_header\n") + 11);
    const size_t at = head.find("element vertex ") + 15;
    std::string wrap = head.substr(0, at) + "9564978408590137875" + head.substr(head.find('\n', at)) + "x";
    std::ofstream(dir / "wrap.ply", std::ios::binary) << wrap;
    const std::string msg = test::error_message_of([&] { io::read_ply((dir / "wrap.ply").string()); });
    assert_non_null(std::strstr(msg.c_str(), "vertex count 9564978408590137875 needs more than the file's 1 bytes"));
    test::expect_error([&] { io::read_ply((dir / "wrap.ply").string()); }, ErrorCode::Format);
    std::ofstream(dir / "neg.ply", std::ios::binary) << head.substr(0, at) + "-1" + head.substr(head.find('\n', at));
    test::expect_error([&] { io::read_ply((dir / "neg.ply").string()); }, ErrorCode::Format);
    test::expect_error([&] { io::scene_points(f, StereoCamera{}, image); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { io::scene_points(f, cam, cv::Mat(4, 7, CV_8UC3)); }, ErrorCode::SizeMismatch);
    assert_true(ply.find("omx") == std::string::npos);  // no ego-motion given: the original nine

    // With the ego-motion T: omx omy omz = X1 - T X0, appended after blue.
    const double a = 0.05;
    const cv::Matx44d T(std::cos(a), 0, std::sin(a), 0.1, 0, 1, 0, -0.02, -std::sin(a), 0, std::cos(a), -0.9, 0, 0, 0, 1);
    const std::vector<io::CloudPoint> om = io::scene_points(f, cam, image, &T);
    assert_int_equal(om.size(), pts.size());
    for (size_t i = 0; i < om.size(); ++i) {
        assert_true(om[i].has_object_motion && !pts[i].has_object_motion);
        const cv::Vec4d x0(om[i].position[0], om[i].position[1], om[i].position[2], 1);
        const cv::Vec4d moved = T * x0;
        for (int k = 0; k < 3; ++k) {
            const double want = om[i].position[k] + om[i].motion[k] - moved[k];
            assert_true(std::fabs(om[i].object_motion[k] - want) < 1e-4 * (1 + std::fabs(want)));
        }
    }
    io::write_ply((dir / "om.ply").string(), om);
    const std::string om_ply = slurp(dir / "om.ply");
    assert_non_null(std::strstr(om_ply.c_str(), "property uchar blue\nproperty float omx\nproperty float omy\n"
                                                "property float omz\nend_header\n"));
    const std::vector<io::CloudPoint> om_back = io::read_ply((dir / "om.ply").string());
    assert_int_equal(om_back.size(), om.size());
    for (size_t i = 0; i < om.size(); ++i)
        assert_true(om_back[i].has_object_motion && om_back[i].object_motion == om[i].object_motion &&
                    om_back[i].position == om[i].position && om_back[i].rgb == om[i].rgb);
    // A reader that knows only the first nine properties finds them where they were, in 39-byte
    // records instead of 27.
    const size_t body = om_ply.find("end_header\n") + 11;
    assert_int_equal(om_ply.size() - body, 39 * om.size());
    for (size_t i = 0; i < om.size(); ++i) {
        float x;
        std::memcpy(&x, om_ply.data() + body + 39 * i, 4);
        assert_true(x == om[i].position[0]);
        assert_true(static_cast<uchar>(om_ply[body + 39 * i + 24]) == om[i].rgb[0]);
    }
    std::vector<io::CloudPoint> mixed = om;
    mixed.back().has_object_motion = false;
    test::expect_error([&] { io::write_ply((dir / "mixed.ply").string(), mixed); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trips),
        cmocka_unit_test(test_bytes_on_disk),
        cmocka_unit_test(test_broken_files),
        cmocka_unit_test(test_headers_checked_before_allocation),
        cmocka_unit_test(test_any_format_readers),
        cmocka_unit_test(test_point_cloud),
    };
    return cmocka_run_group_tests_name("io_result_files", tests, nullptr, nullptr);
}
