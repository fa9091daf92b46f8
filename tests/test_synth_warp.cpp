// SPDX-License-Identifier: MIT
// Synthetic scene: the ground truth explains the images. Warping the other three views into the
// left t0 image with the exact GT must reproduce it at non-occluded pixels (up to sensor noise
// and interpolation); a slightly wrong GT must not.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "synth/scene.hpp"
// cmocka 1.1.5's header lacks extern "C" and its fail() macro breaks <ios>: include it last.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using lidarflow::DisparityMap;
using lidarflow::disparity_valid;
using lidarflow::synth::SynthScene;

namespace {

const SynthScene &scene() {
    static const SynthScene s = lidarflow::synth::render(lidarflow::synth::SynthConfig{});
    return s;
}

double grey(const cv::Mat &img, int y, int x) {
    const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
    return (p[0] + p[1] + p[2]) / 3.0;
}

// Bilinear grey value; false when (x, y) is outside the pixel grid.
bool sample(const cv::Mat &img, double x, double y, double &out) {
    if (!(x >= 0 && y >= 0 && x <= img.cols - 1 && y <= img.rows - 1)) return false;
    const int x0 = std::min(static_cast<int>(x), img.cols - 2), y0 = std::min(static_cast<int>(y), img.rows - 2);
    const double fx = x - x0, fy = y - y0;
    out = (1 - fy) * ((1 - fx) * grey(img, y0, x0) + fx * grey(img, y0, x0 + 1)) +
          fy * ((1 - fx) * grey(img, y0 + 1, x0) + fx * grey(img, y0 + 1, x0 + 1));
    return true;
}

// Interior of a surface: the same surface in the 5x5 window, so the bilinear footprint in the
// other view does not straddle an object boundary. (Every surface is a plane or a convex box,
// so depth discontinuities are exactly label changes.)
bool interior(const SynthScene &s, int y, int x) {
    if (y < 2 || x < 2 || y >= s.labels0.rows - 2 || x >= s.labels0.cols - 2) return false;
    for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
            if (s.labels0(y + dy, x + dx) != s.labels0(y, x)) return false;
    return true;
}

struct WarpStats {
    size_t n = 0;
    double median = 0, within = 0;  // median |diff| and fraction with |diff| <= kTol
};
constexpr double kTol = 8.0;  // grey levels: noise (sigma 1 per image) + interpolation of texture

enum class Target { Right0, Left1, Right1 };

// `bias` is added to the disparity (Right0/Right1) or to u (Left1): a wrong GT for the control.
WarpStats warp_stats(const SynthScene &s, Target target, double bias) {
    std::vector<double> diffs;
    for (int y = 0; y < s.left0.rows; ++y)
        for (int x = 0; x < s.left0.cols; ++x) {
            if (!interior(s, y, x)) continue;
            double tx, ty;
            const cv::Mat *img;
            if (target == Target::Right0) {
                if (!disparity_valid(s.disp0_noc(y, x))) continue;
                tx = x - (s.disp0_noc(y, x) + bias), ty = y, img = &s.right0;
            } else if (target == Target::Left1) {
                if (!s.flow_noc.valid(y, x)) continue;
                tx = x + s.flow_noc.u(y, x) + bias, ty = y + s.flow_noc.v(y, x), img = &s.left1;
            } else {
                if (!s.flow_noc.valid(y, x) || !disparity_valid(s.disp1_noc(y, x))) continue;
                tx = x + s.flow_noc.u(y, x) - (s.disp1_noc(y, x) + bias), ty = y + s.flow_noc.v(y, x);
                img = &s.right1;
            }
            double v;
            if (!sample(*img, tx, ty, v)) continue;
            diffs.push_back(std::fabs(v - grey(s.left0, y, x)));
        }
    WarpStats st;
    st.n = diffs.size();
    if (diffs.empty()) return st;
    std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
    st.median = diffs[diffs.size() / 2];
    st.within = std::count_if(diffs.begin(), diffs.end(), [](double d) { return d <= kTol; }) / double(diffs.size());
    return st;
}

void check_warp(Target target, const char *name) {
    const SynthScene &s = scene();
    const WarpStats exact = warp_stats(s, target, 0.0);
    const WarpStats wrong = warp_stats(s, target, 1.5);
    std::printf("%s: n=%zu median=%.2f within%.0f=%.3f | GT+1.5px: median=%.2f within=%.3f\n", name, exact.n,
                exact.median, kTol, exact.within, wrong.median, wrong.within);
    // Most of the image must take part (the test is not about a handful of pixels).
    assert_true(exact.n > static_cast<size_t>(s.left0.total() / 2));
    assert_true(exact.median <= 3.0);
    assert_true(exact.within >= 0.95);
    // Control: 1.5 px off is clearly visible in the same statistics.
    assert_true(wrong.median >= 2 * exact.median);
    assert_true(wrong.within <= exact.within - 0.05);
}

void test_right0_with_d0(void **) { check_warp(Target::Right0, "right t0 at p-(d0,0)"); }
void test_left1_with_flow(void **) { check_warp(Target::Left1, "left t1 at p+(u,v)"); }
void test_right1_with_flow_and_d1(void **) { check_warp(Target::Right1, "right t1 at p+(u-d1,v)"); }

// Occlusions exist and are excluded from noc: noc is a strict subset of occ for every map.
void test_noc_is_strict_subset_of_occ(void **) {
    const SynthScene &s = scene();
    auto count = [](const DisparityMap &m) {
        return static_cast<size_t>(std::count_if(m.begin(), m.end(), [](float d) { return disparity_valid(d); }));
    };
    size_t noc_not_occ = 0;
    for (int y = 0; y < s.left0.rows; ++y)
        for (int x = 0; x < s.left0.cols; ++x) {
            noc_not_occ += disparity_valid(s.disp0_noc(y, x)) && !disparity_valid(s.disp0_occ(y, x));
            noc_not_occ += disparity_valid(s.disp1_noc(y, x)) && !disparity_valid(s.disp1_occ(y, x));
            noc_not_occ += s.flow_noc.valid(y, x) && !s.flow_occ.valid(y, x);
            // d1 and flow share the t1 correspondence, so their occ masks coincide.
            assert_int_equal(disparity_valid(s.disp1_occ(y, x)), s.flow_occ.valid(y, x) != 0);
        }
    assert_int_equal(noc_not_occ, 0);
    assert_true(count(s.disp0_noc) + 500 < count(s.disp0_occ));
    assert_true(count(s.disp1_noc) + 500 < count(s.disp1_occ));
    assert_true(static_cast<size_t>(cv::countNonZero(s.flow_noc.valid)) + 500 <
                static_cast<size_t>(cv::countNonZero(s.flow_occ.valid)));
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_right0_with_d0),
        cmocka_unit_test(test_left1_with_flow),
        cmocka_unit_test(test_right1_with_flow_and_d1),
        cmocka_unit_test(test_noc_is_strict_subset_of_occ),
    };
    return cmocka_run_group_tests_name("synth_warp", tests, nullptr, nullptr);
}
