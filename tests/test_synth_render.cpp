// SPDX-License-Identifier: MIT
// Synthetic scene renderer: determinism, ground-truth sanity, the textureless and shadowed
// regions, the sparse LiDAR frames, and argument checking.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <set>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
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

using namespace lidarflow;
using synth::SynthConfig;
using synth::SynthScene;

namespace {

const SynthScene &default_scene() {
    static const SynthScene s = synth::render(SynthConfig{});
    return s;
}

SynthConfig small(uint64_t seed) {
    SynthConfig c;
    c.seed = seed;
    c.width = 320;
    c.height = 96;
    return c;
}

bool same(const cv::Mat &a, const cv::Mat &b) {
    return a.size() == b.size() && a.type() == b.type() &&
           (a.empty() || cv::norm(a.reshape(1), b.reshape(1), cv::NORM_INF) == 0);
}

bool same_lidar(const SparseLidar &a, const SparseLidar &b) { return a.points == b.points; }

void test_same_seed_is_bit_identical(void **) {
    SynthConfig c = small(7);
    const SynthScene a = synth::render(c);
    c.threads = 1;  // the thread count must not matter either
    const SynthScene b = synth::render(c);
    assert_true(same(a.left0, b.left0) && same(a.right0, b.right0) && same(a.left1, b.left1) &&
                same(a.right1, b.right1));
    assert_true(same(a.disp0_occ, b.disp0_occ) && same(a.disp1_noc, b.disp1_noc) && same(a.flow_occ.u, b.flow_occ.u) &&
                same(a.flow_noc.valid, b.flow_noc.valid));
    assert_true(same_lidar(a.lidar0, b.lidar0) && same_lidar(a.lidar1, b.lidar1));
}

void test_different_seed_differs(void **) {
    const SynthScene a = synth::render(small(7)), b = synth::render(small(8));
    cv::Mat diff;
    cv::absdiff(a.left0, b.left0, diff);
    const double changed = cv::countNonZero(diff.reshape(1) > 10) / static_cast<double>(diff.total() * 3);
    std::printf("seed 7 vs 8: %.1f %% of channel values differ by > 10\n", 100 * changed);
    assert_true(changed > 0.3);
    assert_false(same(a.disp0_occ, b.disp0_occ));
    assert_false(same_lidar(a.lidar0, b.lidar0));
}

void test_images_and_maps_have_the_configured_shape(void **) {
    const SynthScene &s = default_scene();
    for (const cv::Mat *m : {&s.left0, &s.right0, &s.left1, &s.right1}) {
        assert_int_equal(m->type(), CV_8UC3);
        assert_int_equal(m->cols, 640);
        assert_int_equal(m->rows, 192);
    }
    assert_true(s.camera.valid());
    assert_true(std::fabs(s.camera.fx - 0.58 * 640) < 1e-9 && s.camera.fy == s.camera.fx);
    assert_true(s.camera.baseline == 0.54);
    for (const cv::Mat *m : {static_cast<const cv::Mat *>(&s.disp0_occ), static_cast<const cv::Mat *>(&s.disp1_noc),
                             static_cast<const cv::Mat *>(&s.flow_occ.u), static_cast<const cv::Mat *>(&s.labels0),
                             static_cast<const cv::Mat *>(&s.textureless_mask)})
        assert_true(m->size() == cv::Size(640, 192));
}

// d0 = fx*B/Z > 0 everywhere (the facade closes the scene), noc within occ, d1 consistent
// with the t1 depth where the moved point is the surface seen at t1.
void test_ground_truth_sanity(void **) {
    const SynthScene &s = default_scene();
    const double fb = s.camera.fx * s.camera.baseline;
    size_t d1_checked = 0, d1_agree = 0;
    for (int y = 0; y < 192; ++y)
        for (int x = 0; x < 640; ++x) {
            const float d0 = s.disp0_occ(y, x);
            assert_true(d0 > 0 && std::isfinite(d0));
            assert_true(std::fabs(d0 - fb / s.depth_left0(y, x)) <= 1e-4 * d0);
            const float n0 = s.disp0_noc(y, x);
            assert_true(!disparity_valid(n0) || n0 == d0);
            if (!s.flow_occ.valid(y, x)) continue;
            assert_true(s.disp1_occ(y, x) > 0);
            if (!s.flow_noc.valid(y, x)) continue;
            // Visible at t1: the left t1 depth at the nearest pixel is about the point's depth.
            const int x1 = static_cast<int>(std::lround(x + s.flow_noc.u(y, x)));
            const int y1 = static_cast<int>(std::lround(y + s.flow_noc.v(y, x)));
            const double d1_there = fb / s.depth_left1(y1, x1);
            ++d1_checked;
            d1_agree += std::fabs(d1_there - s.disp1_occ(y, x)) < 0.5;
        }
    std::printf("d1 vs left t1 depth: %zu of %zu agree within 0.5 px\n", d1_agree, d1_checked);
    assert_true(d1_checked > 60000);
    assert_true(d1_agree > 0.97 * d1_checked);
    // The camera moves forward and objects move: flow is not a constant shift.
    double umin = 1e9, umax = -1e9, vmax = 0;
    for (int y = 0; y < 192; ++y)
        for (int x = 0; x < 640; ++x)
            if (s.flow_occ.valid(y, x)) {
                umin = std::min<double>(umin, s.flow_occ.u(y, x));
                umax = std::max<double>(umax, s.flow_occ.u(y, x));
                vmax = std::max<double>(vmax, std::fabs(s.flow_occ.v(y, x)));
            }
    std::printf("flow u in [%.1f, %.1f], |v| <= %.1f\n", umin, umax, vmax);
    assert_true(umax - umin > 10 && vmax > 5);
}

double gradient_magnitude_quantile(const cv::Mat &bgr, const cv::Mat1b &mask, double q) {
    cv::Mat grey, gx, gy;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    cv::Sobel(grey, gx, CV_32F, 1, 0, 3, 1.0 / 8);  // 1/8: derivative in grey levels per pixel
    cv::Sobel(grey, gy, CV_32F, 0, 1, 3, 1.0 / 8);
    std::vector<float> g;
    for (int y = 0; y < grey.rows; ++y)
        for (int x = 0; x < grey.cols; ++x)
            if (mask(y, x)) g.push_back(std::hypot(gx.at<float>(y, x), gy.at<float>(y, x)));
    if (g.empty()) return -1;
    const size_t k = std::min(g.size() - 1, static_cast<size_t>(q * g.size()));
    std::nth_element(g.begin(), g.begin() + k, g.end());
    return g[k];
}

cv::Mat1b erode(const cv::Mat1b &m, int r) {
    cv::Mat1b out;
    cv::erode(m, out, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1)));
    return out;
}

// Textureless box: large, and inside it (away from its outline and from the edge between its
// faces) the image gradient is at the sensor-noise level, unlike on the textured surfaces.
void test_textureless_region_has_no_texture(void **) {
    const SynthScene &s = default_scene();
    const int area = cv::countNonZero(s.textureless_mask);
    assert_true(area > 3000);
    // Pixels whose 7x7 window lies on one face: mask eroded, minus a band around face edges
    // (where the grey level jumps between the per-face shades).
    cv::Mat grey;
    cv::cvtColor(s.left0, grey, cv::COLOR_BGR2GRAY);
    cv::Mat1b core = erode(s.textureless_mask, 3);
    const double tl = gradient_magnitude_quantile(s.left0, core, 0.9);
    cv::Mat1b textured = erode(s.labels0 >= 3, 3) & ~s.textureless_mask;
    const double tx = gradient_magnitude_quantile(s.left0, textured, 0.5);
    std::printf("textureless: %d px, 90th pct gradient %.2f; textured boxes median gradient %.2f\n", area, tl, tx);
    assert_true(tl >= 0 && tl < 2.0);
    assert_true(tx > 4 * tl);
}

// Shadow: a large ground area, dark, and with a fraction of the lit ground's contrast.
void test_shadow_region_is_dark_and_flat(void **) {
    const SynthScene &s = default_scene();
    const int area = cv::countNonZero(s.shadow_mask);
    assert_true(area > 3000);
    cv::Mat grey;
    cv::cvtColor(s.left0, grey, cv::COLOR_BGR2GRAY);
    cv::Mat1b lit = erode((s.labels0 == 1) & ~s.shadow_mask, 3);
    cv::Scalar m_sh, sd_sh, m_lit, sd_lit;
    cv::meanStdDev(grey, m_sh, sd_sh, erode(s.shadow_mask, 3));
    cv::meanStdDev(grey, m_lit, sd_lit, lit);
    std::printf("shadow: %d px, mean %.1f std %.1f; lit ground mean %.1f std %.1f\n", area, m_sh[0], sd_sh[0],
                m_lit[0], sd_lit[0]);
    assert_true(m_sh[0] < 30);
    assert_true(m_lit[0] > 3 * m_sh[0]);
    assert_true(sd_sh[0] < 0.25 * sd_lit[0]);
    // Every shadow pixel is on the ground.
    assert_int_equal(cv::countNonZero(s.shadow_mask & (s.labels0 != 1)), 0);
}

// LiDAR: N points per frame, spread over the image, exact at their pixels (t0: d0 GT, t1: the
// left t1 depth), on two independent grids; some land in each hard region.
void test_lidar_frames(void **) {
    const SynthScene &s = default_scene();
    const double fb = s.camera.fx * s.camera.baseline;
    assert_int_equal(s.lidar0.points.size(), 88);
    assert_int_equal(s.lidar1.points.size(), 88);
    assert_int_equal(s.lidar0.width, 640);
    assert_int_equal(s.lidar1.height, 192);
    int quadrant[4] = {0, 0, 0, 0};
    for (const LidarPoint &p : s.lidar0.points) {
        assert_true(p.disparity == s.disp0_occ(p.y, p.x));
        ++quadrant[(p.x >= 320) + 2 * (p.y >= 96)];
    }
    for (int q : quadrant) assert_true(q >= 10);
    std::set<std::pair<int, int>> at0;
    for (const LidarPoint &p : s.lidar0.points) at0.insert({p.x, p.y});
    int shared = 0;
    for (const LidarPoint &p : s.lidar1.points) {
        assert_true(std::fabs(p.disparity - fb / s.depth_left1(p.y, p.x)) <= 1e-4 * p.disparity);
        shared += at0.count({p.x, p.y}) > 0;
    }
    assert_true(shared <= 2);
    int in_textureless = 0, in_shadow = 0;
    for (const LidarPoint &p : s.lidar0.points) {
        in_textureless += s.textureless_mask(p.y, p.x) != 0;
        in_shadow += s.shadow_mask(p.y, p.x) != 0;
    }
    std::printf("LiDAR t0 points in textureless box: %d, in shadow: %d\n", in_textureless, in_shadow);
    assert_true(in_textureless >= 2 && in_shadow >= 2);
}

void test_lidar_count_and_noise_options(void **) {
    SynthConfig c = small(3);
    c.lidar_points = 200;
    c.lidar_noise = 0.5;
    const SynthScene s = synth::render(c);
    assert_int_equal(s.lidar0.points.size(), 200);
    double sum2 = 0;
    for (const LidarPoint &p : s.lidar0.points) {
        const double e = p.disparity - s.disp0_occ(p.y, p.x);
        assert_true(std::fabs(e) < 5 * 0.5);
        sum2 += e * e;
    }
    const double rms = std::sqrt(sum2 / 200);
    std::printf("LiDAR noise sigma 0.5: measured rms %.3f\n", rms);
    assert_true(rms > 0.35 && rms < 0.65);
    c.lidar_points = 0;
    assert_true(synth::render(c).lidar0.points.empty());
}

void test_sensor_noise_option(void **) {
    SynthConfig c = small(5);
    c.noise_sigma = 0;
    const SynthScene clean = synth::render(c);
    c.noise_sigma = 2.0;
    const SynthScene noisy = synth::render(c);
    cv::Mat a, b;
    clean.left0.convertTo(a, CV_32F);
    noisy.left0.convertTo(b, CV_32F);
    cv::Scalar mean, sd;
    const cv::Mat d = b - a;
    cv::meanStdDev(d.reshape(1), mean, sd);
    std::printf("noise sigma 2: measured mean %.3f std %.3f\n", mean[0], sd[0]);
    assert_true(std::fabs(mean[0]) < 0.1 && sd[0] > 1.8 && sd[0] < 2.2);
    assert_true(same(clean.disp0_occ, noisy.disp0_occ));  // noise never touches the GT
}

bool throws_invalid(const std::function<void(SynthConfig &)> &edit) {
    SynthConfig c = small(1);
    edit(c);
    try {
        synth::render(c);
    } catch (const Error &e) {
        return e.code() == ErrorCode::InvalidArgument;
    }
    return false;
}

void test_bad_config_is_rejected(void **) {
    assert_true(throws_invalid([](SynthConfig &c) { c.width = 0; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.height = 10; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.width = 100000; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.fx = std::nan(""); }));
    assert_true(throws_invalid([](SynthConfig &c) { c.fx = -1; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.baseline = 0; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.baseline = INFINITY; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.noise_sigma = -1; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.lidar_noise = std::nan(""); }));
    assert_true(throws_invalid([](SynthConfig &c) { c.lidar_points = -1; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.lidar_points = 320 * 96 + 1; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.supersampling = 0; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.supersampling = 9; }));
    assert_true(throws_invalid([](SynthConfig &c) { c.threads = -2; }));
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_seed_is_bit_identical),
        cmocka_unit_test(test_different_seed_differs),
        cmocka_unit_test(test_images_and_maps_have_the_configured_shape),
        cmocka_unit_test(test_ground_truth_sanity),
        cmocka_unit_test(test_textureless_region_has_no_texture),
        cmocka_unit_test(test_shadow_region_is_dark_and_flat),
        cmocka_unit_test(test_lidar_frames),
        cmocka_unit_test(test_lidar_count_and_noise_options),
        cmocka_unit_test(test_sensor_noise_option),
        cmocka_unit_test(test_bad_config_is_rejected),
    };
    return cmocka_run_group_tests_name("synth_render", tests, nullptr, nullptr);
}
