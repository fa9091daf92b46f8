// SPDX-License-Identifier: MIT
// KITTI disparity / flow PNG codecs (io/kitti_png): devkit encoding rules on synthetic maps,
// bit-exact read -> write -> read of the real ground truth, and errors for bad files.
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>

#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
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


bool same_raw(const cv::Mat &a, const cv::Mat &b) {
    if (a.empty() || b.empty() || a.size() != b.size() || a.type() != b.type()) return false;
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    return cv::countNonZero(diff.reshape(1)) == 0;
}

cv::Mat raw(const fs::path &p) { return cv::imread(p.string(), cv::IMREAD_UNCHANGED); }

void test_disparity_encoding_rules(void **) {
    const fs::path dir = test::scratch_dir("io_kitti_disp");
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    // value written -> value read back, per the devkit: max(d * 256, 1) truncated, clamped.
    const float in[] = {0.0f, 1.0f, 1.999f, 300.0f, 0.001f, -1.0f, nan, inf, 12.5f, -0.5f};
    const float want[] = {1 / 256.0f, 1.0f, 511 / 256.0f, 65535 / 256.0f, 1 / 256.0f,
                          -1.0f,      -1.0f, 65535 / 256.0f, 12.5f, -1.0f};
    const int n = static_cast<int>(sizeof in / sizeof in[0]);
    DisparityMap d(2, n);
    for (int i = 0; i < n; ++i) d(0, i) = in[i], d(1, i) = static_cast<float>(i) + 0.25f;
    const fs::path p1 = dir / "a.png", p2 = dir / "sub" / "b.png";
    io::write_disparity_png(p1.string(), d);
    const cv::Mat r1 = raw(p1);
    assert_int_equal(r1.type(), CV_16UC1);
    assert_int_equal(r1.at<uint16_t>(0, 5), 0);  // invalid is stored as 0
    assert_int_equal(r1.at<uint16_t>(0, 0), 1);  // a valid 0 survives as 1/256
    const DisparityMap back = io::read_disparity_png(p1.string());
    assert_int_equal(back.cols, n);
    for (int i = 0; i < n; ++i) {
        assert_true(back(0, i) == want[i]);
        assert_true(back(1, i) == static_cast<float>(i) + 0.25f);
    }
    // Second generation: writing what was read gives the same bytes (creates sub/ on the way).
    io::write_disparity_png(p2.string(), back);
    assert_true(same_raw(r1, raw(p2)));
}

void test_flow_encoding_rules(void **) {
    const fs::path dir = test::scratch_dir("io_kitti_flow");
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float in_u[] = {-3.5f, 0.3f, -0.3f, 600.0f, -600.0f, 0.0f, 7.0f, nan};
    const float want_u[] = {-3.5f, 19 / 64.0f, -20 / 64.0f, 32767 / 64.0f, -512.0f, 0.0f, 0.0f, 0.0f};
    const uint8_t valid[] = {1, 1, 1, 1, 1, 1, 0, 1};
    const int n = static_cast<int>(sizeof in_u / sizeof in_u[0]);
    FlowField f = FlowField::zeros(n, 1);
    for (int i = 0; i < n; ++i) {
        f.u(0, i) = in_u[i];
        f.v(0, i) = 10.25f - static_cast<float>(i);
        f.valid(0, i) = valid[i];
    }
    const fs::path p1 = dir / "a.png", p2 = dir / "b.png";
    io::write_flow_png(p1.string(), f);
    const cv::Mat r1 = raw(p1);
    assert_int_equal(r1.type(), CV_16UC3);
    // OpenCV order: B = valid, G = v, R = u; invalid (and non-finite) pixels are all zero.
    assert_true(r1.at<cv::Vec3w>(0, 0) == cv::Vec3w(1, static_cast<uint16_t>(32768 + 10.25 * 64), 32768 - 224));
    assert_true(r1.at<cv::Vec3w>(0, 6) == cv::Vec3w(0, 0, 0));
    assert_true(r1.at<cv::Vec3w>(0, 7) == cv::Vec3w(0, 0, 0));
    const FlowField back = io::read_flow_png(p1.string());
    for (int i = 0; i < n; ++i) {
        const bool ok = valid[i] && !std::isnan(in_u[i]);
        assert_int_equal(back.valid(0, i), ok ? 1 : 0);
        assert_true(back.u(0, i) == want_u[i]);
        assert_true(back.v(0, i) == (ok ? 10.25f - static_cast<float>(i) : 0.0f));
    }
    io::write_flow_png(p2.string(), back);
    assert_true(same_raw(r1, raw(p2)));
}

void test_bad_files(void **) {
    const fs::path dir = test::scratch_dir("io_kitti_bad");
    assert_true(throws_code(ErrorCode::Io, [&] { io::read_disparity_png((dir / "missing.png").string()); }));
    assert_true(throws_code(ErrorCode::Io, [&] { io::read_flow_png((dir / "missing.png").string()); }));
    assert_true(throws_code(ErrorCode::Io, [&] { io::read_image((dir / "missing.png").string()); }));

    const fs::path junk = dir / "junk.png";
    std::ofstream(junk, std::ios::binary) << "definitely not a PNG file";
    assert_true(throws_code(ErrorCode::Format, [&] { io::read_disparity_png(junk.string()); }));
    assert_true(throws_code(ErrorCode::Format, [&] { io::read_flow_png(junk.string()); }));

    // A valid 16-bit PNG cut in half.
    const fs::path full = dir / "full.png", cut = dir / "cut.png";
    cv::Mat1w big(64, 64);
    cv::randu(big, 0, 65535);
    assert_true(cv::imwrite(full.string(), big));
    const auto size = fs::file_size(full);
    fs::copy_file(full, cut);
    fs::resize_file(cut, size / 2);
    assert_true(throws_code(ErrorCode::Format, [&] { io::read_disparity_png(cut.string()); }));

    // Wrong PNG types.
    const fs::path gray8 = dir / "gray8.png", rgb16 = dir / "rgb16.png", gray16 = dir / "gray16.png";
    assert_true(cv::imwrite(gray8.string(), cv::Mat1b(4, 4, uint8_t(7))));
    assert_true(cv::imwrite(rgb16.string(), cv::Mat(4, 4, CV_16UC3, cv::Scalar(1, 2, 3))));
    assert_true(cv::imwrite(gray16.string(), cv::Mat1w(4, 4, uint16_t(300))));
    assert_true(throws_code(ErrorCode::Format, [&] { io::read_disparity_png(gray8.string()); }));
    assert_true(throws_code(ErrorCode::Format, [&] { io::read_disparity_png(rgb16.string()); }));
    assert_true(throws_code(ErrorCode::Format, [&] { io::read_flow_png(gray16.string()); }));
    assert_true(throws_code(ErrorCode::Format, [&] { io::read_image(gray16.string()); }));

    // Writers: nothing to write, mismatched planes, unwritable target (a file as parent folder).
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { io::write_disparity_png((dir / "e.png").string(), DisparityMap()); }));
    FlowField bad = FlowField::zeros(4, 4);
    bad.v = cv::Mat1f::zeros(3, 4);
    assert_true(throws_code(ErrorCode::SizeMismatch, [&] { io::write_flow_png((dir / "f.png").string(), bad); }));
    assert_true(throws_code(ErrorCode::Io, [&] {
        io::write_disparity_png((junk / "x.png").string(), DisparityMap(2, 2, 1.0f));
    }));
}

// Every ground-truth PNG of the shared frames survives read -> write -> read bit-exactly, and
// the decoded values follow the devkit formulas on the raw data.
void test_real_ground_truth_bit_exact(void **) {
    const std::string root = test::kitti_dir();
    if (root.empty()) {
        std::printf("KITTI frames not available (LIDARFLOW_KITTI_DIR): skipped\n");
        skip();
    }
    const io::KittiLayout L{root};
    const fs::path dir = test::scratch_dir("io_kitti_real");
    int files = 0;
    for (const std::string &id : L.frame_ids()) {
        for (const std::string &p : {L.gt_disp0(id, true), L.gt_disp0(id, false), L.gt_disp1(id, true),
                                     L.gt_disp1(id, false)}) {
            const cv::Mat r = raw(p);
            const DisparityMap d = io::read_disparity_png(p);
            for (int y = 0; y < r.rows; y += 7)
                for (int x = 0; x < r.cols; x += 5) {
                    const uint16_t v = r.at<uint16_t>(y, x);
                    assert_true(d(y, x) == (v ? v / 256.0f : kInvalidDisparity));
                }
            const fs::path out = dir / ("d" + std::to_string(files++) + ".png");
            io::write_disparity_png(out.string(), d);
            assert_true(same_raw(r, raw(out)));
        }
        for (const std::string &p : {L.gt_flow(id, true), L.gt_flow(id, false)}) {
            const cv::Mat r = raw(p);
            const FlowField f = io::read_flow_png(p);
            for (int y = 0; y < r.rows; y += 7)
                for (int x = 0; x < r.cols; x += 5) {
                    const cv::Vec3w v = r.at<cv::Vec3w>(y, x);
                    assert_int_equal(f.valid(y, x), v[0] ? 1 : 0);
                    if (v[0]) assert_true(f.u(y, x) == (v[2] - 32768.0f) / 64.0f);
                }
            // KITTI's ground truth stores invalid pixels as (u, v) = (2^15, 2^15) raw, i.e. zero
            // flow, while the devkit writer (and ours) stores (0, 0, 0): the bytes agree on the
            // valid flag everywhere and on u, v wherever the flag is set.
            const fs::path out = dir / ("f" + std::to_string(files++) + ".png");
            io::write_flow_png(out.string(), f);
            const cv::Mat w = raw(out);
            assert_true(w.type() == r.type() && w.size() == r.size());
            long differing = 0;
            for (int y = 0; y < r.rows; ++y)
                for (int x = 0; x < r.cols; ++x) {
                    const cv::Vec3w a = r.at<cv::Vec3w>(y, x), b = w.at<cv::Vec3w>(y, x);
                    differing += a[0] != b[0] || (a[0] && a != b) || (!a[0] && b != cv::Vec3w(0, 0, 0));
                }
            assert_int_equal(differing, 0);
            // The second generation is byte-identical, and decodes to the same field.
            const fs::path out2 = dir / ("f" + std::to_string(files++) + ".png");
            const FlowField f2 = io::read_flow_png(out.string());
            io::write_flow_png(out2.string(), f2);
            assert_true(same_raw(w, raw(out2)));
            assert_int_equal(cv::countNonZero(f2.valid != f.valid), 0);
            assert_int_equal(cv::countNonZero(f2.u != f.u), 0);
            assert_int_equal(cv::countNonZero(f2.v != f.v), 0);
        }
    }
    assert_true(files >= 8);
    std::printf("%d PNGs written from the ground truth, all byte-checked\n", files);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_disparity_encoding_rules),
        cmocka_unit_test(test_flow_encoding_rules),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_real_ground_truth_bit_exact),
    };
    return cmocka_run_group_tests_name("io_kitti", tests, nullptr, nullptr);
}
