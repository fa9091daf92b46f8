// SPDX-License-Identifier: MIT
// Visualisation: flow colour wheels, disparity colour map, KITTI error images, overlays, the keys
// below the pictures and the bird's-eye view's.
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

#include "core/error.hpp"
#include "viz/birds_eye.hpp"
#include "viz/disparity_color.hpp"
#include "viz/error_map.hpp"
#include "viz/flow_color.hpp"
#include "viz/legend.hpp"
#include "viz/overlay.hpp"
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
using test::throws_code;

namespace {

FlowField one_row(std::initializer_list<std::pair<float, float>> uv) {
    FlowField f = FlowField::zeros(static_cast<int>(uv.size()), 1);
    int i = 0;
    for (const auto &p : uv) {
        f.u(0, i) = p.first;
        f.v(0, i) = p.second;
        f.valid(0, i) = 1;
        ++i;
    }
    return f;
}

bool near(const cv::Vec3b &a, int b, int g, int r, int tol = 1) {
    return std::abs(a[0] - b) <= tol && std::abs(a[1] - g) <= tol && std::abs(a[2] - r) <= tol;
}

// KITTI style: hue from direction, full saturation from max/8 on, white at rest, black invalid.
void test_kitti_flow_wheel(void **) {
    FlowField f = one_row({{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}, {8, 0}, {4, 0}, {0.5f, 0}});
    f.valid(0, 7) = 0;
    viz::FlowColorOptions o;
    o.max_flow = 8;  // |f| = 1 saturates exactly (8 |f| / max = 1), |f| = 8 is black
    const cv::Mat c = viz::flow_to_color(f, o);
    assert_int_equal(c.type(), CV_8UC3);
    assert_true(c.size() == cv::Size(8, 1));
    const auto px = [&](int i) { return c.at<cv::Vec3b>(0, i); };
    assert_true(near(px(0), 255, 255, 255));  // zero flow: white
    assert_true(near(px(1), 0, 0, 255));      // +u: red (BGR)
    assert_true(near(px(2), 255, 255, 0));    // -u: cyan
    assert_true(near(px(3), 0, 255, 128));    // +v (down): hue 90 deg, chartreuse
    assert_true(near(px(4), 255, 0, 128));    // -v (up): hue 270 deg, violet
    assert_true(near(px(5), 0, 0, 0));        // |f| = max: darkened to black
    assert_true(near(px(6), 0, 0, 255));      // half of max: still full red
    assert_true(near(px(7), 0, 0, 0));        // invalid: black
    // Automatic normalisation: max(|u|, |v|) over valid pixels, so scaling the field keeps colours.
    FlowField g = one_row({{0.5f, 0}, {3, 1}, {-2, 20}});
    FlowField g10 = one_row({{5, 0}, {30, 10}, {-20, 200}});
    assert_true(cv::norm(viz::flow_to_color(g), viz::flow_to_color(g10), cv::NORM_INF) <= 1);
}

void test_middlebury_flow_wheel(void **) {
    const FlowField f = one_row({{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {2, 0}});
    viz::FlowColorOptions o;
    o.style = viz::FlowColorStyle::Middlebury;
    o.max_flow = 1;
    const cv::Mat c = viz::flow_to_color(f, o);
    const auto px = [&](int i) { return c.at<cv::Vec3b>(0, i); };
    assert_true(near(px(0), 255, 255, 255));
    assert_true(px(1)[2] > 200 && px(1)[1] < 40);   // +u: red
    assert_true(px(2)[0] > 200 && px(2)[2] < 40);   // -u: blue/cyan side
    assert_true(px(3)[1] > 200 && px(3)[2] > 120);  // +v: yellow-green side
    // Beyond max: the same hue at 75 % brightness.
    assert_true(std::abs(px(4)[2] - static_cast<int>(std::lround(0.75 * px(1)[2]))) <= 1);
}

void test_flow_color_errors(void **) {
    FlowField f = FlowField::zeros(4, 3);
    FlowField bad = f;
    bad.v = cv::Mat1f::zeros(2, 4);
    assert_true(throws_code(ErrorCode::SizeMismatch, [&] { viz::flow_to_color(bad); }));
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { viz::flow_to_color(FlowField{}); }));
    viz::FlowColorOptions o;
    o.max_flow = std::numeric_limits<float>::quiet_NaN();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { viz::flow_to_color(f, o); }));
    // NaN flow marked valid is drawn as invalid, not as garbage.
    f.valid.setTo(1);
    f.u(1, 1) = std::numeric_limits<float>::quiet_NaN();
    const cv::Mat c = viz::flow_to_color(f);
    assert_true(near(c.at<cv::Vec3b>(1, 1), 0, 0, 0));
    assert_true(near(c.at<cv::Vec3b>(0, 0), 255, 255, 255));
}

// Devkit disparity map: 0 black, max white, blue then red on the way up; invalid black.
void test_disparity_colors(void **) {
    DisparityMap d(1, 6);
    d << 0.0f, 10.0f, 20.0f, 40.0f, kInvalidDisparity, 80.0f;
    const cv::Mat c = viz::disparity_to_color(d, 40.0f);
    assert_int_equal(c.type(), CV_8UC3);
    const auto px = [&](int i) { return c.at<cv::Vec3b>(0, i); };
    assert_true(near(px(0), 0, 0, 0));
    assert_true(near(px(3), 255, 255, 255));
    assert_true(near(px(4), 0, 0, 0));
    assert_true(near(px(5), 255, 255, 255));  // above max saturates
    // 0.114 of the range is pure blue (the end of the first segment).
    DisparityMap e(1, 1, 0.114f * 40.0f);
    assert_true(near(viz::disparity_to_color(e, 40.0f).at<cv::Vec3b>(0, 0), 255, 0, 0));
    // Distinct disparities give distinct colours, and automatic max = largest valid value.
    assert_false(near(px(1), px(2)[0], px(2)[1], px(2)[2], 10));
    assert_true(cv::norm(viz::disparity_to_color(d), viz::disparity_to_color(d, 80.0f), cv::NORM_INF) == 0);
    assert_true(throws_code(ErrorCode::InvalidArgument, [] { viz::disparity_to_color(DisparityMap()); }));
}

// Error bands in order of the normalised error; occluded-only pixels at half brightness;
// pixels without GT black; invalid estimates in the worst band.
void test_error_image_bands(void **) {
    // With |gt| = 10 the 3 px term binds (20 e / 10 > e / 3): n = e / 3. Error k sits in the
    // middle of band k (band k >= 1 starts at 2^(k-5)).
    const int n = 10;
    DisparityMap gt(1, n + 2, 10.0f), est(1, n + 2);
    for (int k = 0; k < n; ++k) est(0, k) = 10.0f + (k == 0 ? 0.0f : static_cast<float>(4.5 * std::ldexp(1.0, k - 5)));
    est(0, n) = kInvalidDisparity;     // invalid estimate, valid GT
    gt(0, n + 1) = kInvalidDisparity;  // no GT
    est(0, n + 1) = 5.0f;
    const cv::Mat c = viz::disparity_error_image(est, gt);
    assert_int_equal(c.type(), CV_8UC3);
    assert_true(c.size() == gt.size());
    for (int k = 0; k < n; ++k)
        assert_true(c.at<cv::Vec3b>(0, k) == viz::log_error_color(k == 0 ? 0.0 : 1.5 * std::ldexp(1.0, k - 5)));
    // The devkit's end colours, and bands that really differ.
    assert_true(c.at<cv::Vec3b>(0, 0) == cv::Vec3b(149, 54, 49));      // tiny error: dark blue (BGR)
    assert_true(c.at<cv::Vec3b>(0, 5) == cv::Vec3b(144, 224, 254));   // just above the threshold
    assert_true(c.at<cv::Vec3b>(0, n - 1) == cv::Vec3b(38, 0, 165));   // huge error: dark red
    assert_true(c.at<cv::Vec3b>(0, n) == cv::Vec3b(38, 0, 165));
    assert_true(c.at<cv::Vec3b>(0, n + 1) == cv::Vec3b(0, 0, 0));
    for (int k = 1; k < n; ++k) assert_true(c.at<cv::Vec3b>(0, k) != c.at<cv::Vec3b>(0, k - 1));
    // Bands change monotonically from blue to red: red channel rises then falls only at the top.
    for (int k = 1; k < 6; ++k) assert_true(c.at<cv::Vec3b>(0, k)[2] > c.at<cv::Vec3b>(0, k - 1)[2]);
    // Which term binds: e = 2 on |gt| = 10 gives min(2/3, 4); e = 0.5 on |gt| = 20 gives min(1/6, 1/2).
    DisparityMap g2(1, 1, 10.0f), e2(1, 1, 12.0f);
    assert_true(viz::disparity_error_image(e2, g2).at<cv::Vec3b>(0, 0) == viz::log_error_color(0.667));
    DisparityMap g3(1, 1, 20.0f), e3(1, 1, 20.5f);
    assert_true(viz::disparity_error_image(e3, g3).at<cv::Vec3b>(0, 0) == viz::log_error_color(0.167));
    // Occluded-only pixels (noc invalid) at half brightness.
    DisparityMap noc = gt.clone();
    noc(0, 0) = kInvalidDisparity;
    const cv::Mat h = viz::disparity_error_image(est, gt, noc);
    assert_true(h.at<cv::Vec3b>(0, 0) == cv::Vec3b(149 / 2, 54 / 2, 49 / 2));
    assert_true(h.at<cv::Vec3b>(0, 1) == c.at<cv::Vec3b>(0, 1));
}

void test_flow_error_image(void **) {
    FlowField gt = one_row({{3, 4}, {3, 4}, {3, 4}, {0, 0}});
    FlowField est = one_row({{3, 4}, {3.3f, 4.4f}, {9, 12}, {0, 0}});
    est.valid(0, 3) = 0;  // invalid estimate: worst band
    const cv::Mat c = viz::flow_error_image(est, gt);
    assert_true(c.at<cv::Vec3b>(0, 0) == viz::log_error_color(0));
    // e = 0.5, |gt| = 5: n = min(0.167, 2) -> band [1/8, 1/4)
    assert_true(c.at<cv::Vec3b>(0, 1) == viz::log_error_color(0.167));
    // e = 10: n = min(3.33, 40) -> band [2, 4)
    assert_true(c.at<cv::Vec3b>(0, 2) == viz::log_error_color(3.33));
    assert_true(c.at<cv::Vec3b>(0, 3) == viz::log_error_color(std::numeric_limits<double>::infinity()));
    gt.valid(0, 2) = 0;
    assert_true(viz::flow_error_image(est, gt).at<cv::Vec3b>(0, 2) == cv::Vec3b(0, 0, 0));
    // Linear mode: grey = min(e, 5) / 5.
    viz::ErrorImageOptions lin;
    lin.log_colors = false;
    const cv::Mat l = viz::flow_error_image(est, one_row({{3, 4}, {3, 4}, {3, 4}, {0, 0}}), {}, lin);
    assert_true(l.at<cv::Vec3b>(0, 0) == cv::Vec3b(0, 0, 0));
    assert_true(near(l.at<cv::Vec3b>(0, 1), 26, 26, 26));  // e = 0.5: 25.5
    assert_true(l.at<cv::Vec3b>(0, 2) == cv::Vec3b(255, 255, 255));
    // Dilation paints 3x3 blocks around sparse GT.
    FlowField big = FlowField::zeros(5, 5), big_est = FlowField::zeros(5, 5);
    big.valid(2, 2) = 1;
    big.u(2, 2) = 1;
    viz::ErrorImageOptions dil;
    dil.dilate = true;
    const cv::Mat d = viz::flow_error_image(big_est, big, {}, dil);
    int painted = 0;
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 5; ++x) painted += d.at<cv::Vec3b>(y, x) != cv::Vec3b(0, 0, 0);
    assert_int_equal(painted, 9);
    // Size mismatches are errors.
    assert_true(throws_code(ErrorCode::SizeMismatch, [&] { viz::flow_error_image(est, big); }));
    assert_true(throws_code(ErrorCode::SizeMismatch,
                            [&] { viz::disparity_error_image(DisparityMap(2, 2, 1.0f), DisparityMap(2, 3, 1.0f)); }));
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { viz::flow_error_image(FlowField{}, gt); }));
}

void test_overlays_and_tiles(void **) {
    cv::Mat img(20, 30, CV_8UC3, cv::Scalar(50, 60, 70));
    SparseLidar l;
    l.width = 30;
    l.height = 20;
    l.points = {{10, 10, 5.0f}};
    const cv::Mat dots = viz::draw_lidar(img, l, 5.0f, 2);
    assert_true(dots.at<cv::Vec3b>(10, 10) == cv::Vec3b(255, 255, 255));  // max disparity: white
    assert_true(dots.at<cv::Vec3b>(0, 0) == cv::Vec3b(50, 60, 70));
    assert_true(img.at<cv::Vec3b>(10, 10) == cv::Vec3b(50, 60, 70));  // input untouched
    l.width = 31;
    assert_true(throws_code(ErrorCode::SizeMismatch, [&] { viz::draw_lidar(img, l); }));

    cv::Mat1b mask = cv::Mat1b::zeros(20, 30);
    mask(5, 5) = 255;
    const cv::Mat o = viz::overlay_mask(img, mask, cv::Scalar(250, 0, 0), 0.5);
    assert_true(o.at<cv::Vec3b>(5, 5) == cv::Vec3b(150, 30, 35));
    assert_true(o.at<cv::Vec3b>(6, 6) == cv::Vec3b(50, 60, 70));
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { viz::overlay_mask(img, mask, cv::Scalar(), 1.5); }));

    const cv::Mat t = viz::tile({img, img, img}, 2);
    assert_int_equal(t.cols, 2 * 30 + 4);
    assert_int_equal(t.rows, 2 * 20 + 4);
    assert_true(t.at<cv::Vec3b>(24 + 5, 5) == cv::Vec3b(50, 60, 70));  // third image, second row
    assert_true(t.at<cv::Vec3b>(24 + 5, 34 + 5) == cv::Vec3b(0, 0, 0));  // empty cell
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { viz::tile({}, 2); }));
}

// Colour-bar ticks at multiples of 1, 2 or 5 x 10^k, at most 5 steps over the range.
void test_round_ticks(void **) {
    auto same = [](const std::vector<double> &a, std::initializer_list<double> b) {
        if (a.size() != b.size()) return false;
        size_t i = 0;
        for (double v : b)
            if (std::fabs(a[i++] - v) > 1e-9) return false;
        return true;
    };
    assert_true(same(viz::round_ticks(0, 88.8), {0, 20, 40, 60, 80}));  // was 0, 22.2, 44.4, ...
    assert_true(same(viz::round_ticks(0, 17.3), {0, 5, 10, 15}));
    assert_true(same(viz::round_ticks(0, 100), {0, 20, 40, 60, 80, 100}));
    assert_true(same(viz::round_ticks(0, 1), {0, 0.2, 0.4, 0.6, 0.8, 1.0}));
    assert_true(same(viz::round_ticks(0, 0.37), {0, 0.1, 0.2, 0.3}));
    assert_true(same(viz::round_ticks(-3, 7), {-2, 0, 2, 4, 6}));
    assert_true(same(viz::round_ticks(0, 255), {0, 100, 200}));  // 50 would cut it into 5.1 steps
    assert_true(std::fabs(viz::round_tick_step(0, 4000) - 1000) < 1e-9);
    assert_true(throws_code(ErrorCode::InvalidArgument, [] { viz::round_ticks(1, 1); }));
    assert_true(throws_code(ErrorCode::InvalidArgument, [] { viz::round_ticks(0, std::nan("")); }));
}

// The error maps' legend: the picture unchanged on top, below it all ten bands of the log scale
// and the threshold drawn in white between band 4 (below 1) and band 5 (from 1 on).
void test_error_legend(void **) {
    const cv::Mat map(40, 120, CV_8UC3, cv::Scalar(1, 2, 3));
    const cv::Mat l = viz::with_error_legend(map);
    assert_true(l.rows > 40 + 40 && l.cols >= 400);
    assert_int_equal(cv::norm(l(cv::Rect(0, 0, 120, 40)), map, cv::NORM_INF), 0);
    const cv::Mat strip = l(cv::Rect(0, 40, l.cols, l.rows - 40));
    const double lower[10] = {0, 1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 2, 1, 2, 4, 8, 16};
    int first_x[10];
    for (int k = 0; k < 10; ++k) {
        const cv::Vec3b c = viz::log_error_color(lower[k]);
        first_x[k] = -1;
        for (int x = 0; x < strip.cols && first_x[k] < 0; ++x)
            for (int y = 0; y < strip.rows; ++y)
                if (strip.at<cv::Vec3b>(y, x) == c) {
                    first_x[k] = x;
                    break;
                }
        if (first_x[k] < 0) fail_msg("band %d's colour is not in the legend", k);
        if (k > 0) assert_true(first_x[k] > first_x[k - 1]);  // left to right
    }
    bool white = false;
    for (int x = first_x[4]; x < first_x[5] + 3; ++x)
        for (int y = 0; y < strip.rows; ++y) white = white || strip.at<cv::Vec3b>(y, x) == cv::Vec3b(255, 255, 255);
    assert_true(white);
    assert_true(throws_code(ErrorCode::InvalidArgument, [] { viz::with_error_legend(cv::Mat()); }));
}

// A key to marks: the picture unchanged on top, below it a row per mark with its glyph.
void test_marks_legend(void **) {
    const cv::Mat map(30, 50, CV_8UC3, cv::Scalar(1, 2, 3));
    using Mark = viz::LegendMark;
    const std::vector<Mark> marks = {{Mark::Glyph::Swatch, cv::Scalar(255, 255, 0), "textureless"},
                                     {Mark::Glyph::Swatch, cv::Scalar(255, 0, 255), "shadow"},
                                     {Mark::Glyph::Arrow, cv::Scalar(0, 0, 255), "motion"}};
    const cv::Mat l = viz::with_marks_legend(map, marks);
    assert_true(l.rows >= 30 + 3 * 18 && l.cols > 50);  // widened to fit the labels
    assert_int_equal(cv::norm(l(cv::Rect(0, 0, 50, 30)), map, cv::NORM_INF), 0);
    const cv::Mat strip = l(cv::Rect(0, 30, l.cols, l.rows - 30));
    for (const Mark &m : marks) {
        const cv::Vec3b c(static_cast<uchar>(m.color[0]), static_cast<uchar>(m.color[1]), static_cast<uchar>(m.color[2]));
        int n = 0;
        for (int y = 0; y < strip.rows; ++y)
            for (int x = 0; x < 40; ++x) n += strip.at<cv::Vec3b>(y, x) == c;
        if (n < 5) fail_msg("mark '%s': its colour is not drawn in the key (%d px)", m.label.c_str(), n);
    }
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { viz::with_marks_legend(map, {}); }));
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { viz::with_marks_legend(cv::Mat(), marks); }));
}

// The bird's-eye view: its key explains the camera, the arrows and the distance lines below the
// speed bar, and a distance line just below the top edge has its label under it, not cut off.
void test_birds_eye_key_and_top_label(void **) {
    std::vector<io::CloudPoint> cloud;
    for (int i = 0; i < 400; ++i) {  // a moving wall 3 m right of the camera, away from the labels
        io::CloudPoint p;
        p.position = cv::Vec3f(3.0f + 0.001f * static_cast<float>(i % 20), 0, 2.0f + 0.02f * static_cast<float>(i));
        p.motion = cv::Vec3f(0, 0, 0.5f);
        cloud.push_back(p);
    }
    viz::BirdsEyeOptions o;
    o.range = 10.2;  // the 10 m line lies 12 px below the top edge
    o.height = 600;
    const cv::Mat view = viz::birds_eye_view(cloud, o);
    assert_true(view.rows >= 600 + 40 + 3 * 18);
    // The marks' key: the white camera triangle and arrow glyphs below the speed bar's strip.
    const cv::Mat key = view(cv::Rect(0, 600 + 44, view.cols, view.rows - 600 - 44));
    assert_true(cv::countNonZero(key.reshape(1) == 255) > 20);
    const int line_y = static_cast<int>(std::lround((10.2 - 10.0) * 600 / 10.2));
    auto label_pixels = [&](int y0, int y1) {
        int n = 0;
        for (int y = std::max(0, y0); y < y1; ++y)
            for (int x = 2; x < 40; ++x) {
                const cv::Vec3b c = view.at<cv::Vec3b>(y, x);
                n += c[0] > 100 && c[0] == c[1] && c[1] == c[2];
            }
        return n;
    };
    assert_true(label_pixels(line_y + 2, line_y + 18) > 10);  // "10 m" under its line
    assert_int_equal(label_pixels(0, line_y - 1), 0);         // nothing cut at the top edge
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kitti_flow_wheel),
        cmocka_unit_test(test_middlebury_flow_wheel),
        cmocka_unit_test(test_flow_color_errors),
        cmocka_unit_test(test_disparity_colors),
        cmocka_unit_test(test_error_image_bands),
        cmocka_unit_test(test_flow_error_image),
        cmocka_unit_test(test_overlays_and_tiles),
        cmocka_unit_test(test_round_ticks),
        cmocka_unit_test(test_error_legend),
        cmocka_unit_test(test_marks_legend),
        cmocka_unit_test(test_birds_eye_key_and_top_label),
    };
    return cmocka_run_group_tests_name("viz_colors", tests, nullptr, nullptr);
}
