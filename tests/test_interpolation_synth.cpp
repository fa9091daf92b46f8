// SPDX-License-Identifier: MIT
// Stage 4 on the synthetic street scene (src/synth, exact ground truth): sparse GT matches
// with gross outliers + the scene's 88 LiDAR points -> dense scene flow with bounded KITTI
// outlier rates, and LiDAR never makes it worse.
#include "test_support.hpp"

#include <cmath>
#include <cstdio>

#include "interpolation/interpolator.hpp"
#include "interpolation_scene.hpp"
#include "synth/scene.hpp"

using namespace lidarflow;

namespace {

struct Case {
    synth::SynthScene scene;
    SceneFlowField truth, matches;
};

const Case &the_case() {
    static const Case c = [] {
        Case k;
        synth::SynthConfig cfg;
        cfg.width = 640;
        cfg.height = 192;
        cfg.seed = 3;
        k.scene = synth::render(cfg);
        const int w = cfg.width, h = cfg.height;
        k.truth = SceneFlowField::zeros(w, h);
        const synth::SynthScene &s = k.scene;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                if (s.disp0_occ(y, x) < 0 || s.disp1_occ(y, x) < 0 || !s.flow_occ.valid(y, x)) continue;
                k.truth.u(y, x) = s.flow_occ.u(y, x);
                k.truth.v(y, x) = s.flow_occ.v(y, x);
                k.truth.d0(y, x) = s.disp0_occ(y, x);
                k.truth.d1(y, x) = s.disp1_occ(y, x);
                k.truth.valid(y, x) = 1;
            }
        // 5 % of the GT pixels, 5 % of those gross outliers; LiDAR pixels are exact matches.
        k.matches = test::sample_matches(k.truth, 0.05, 0.05, 21);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                if (!k.truth.valid(y, x)) k.matches.valid(y, x) = 0;
        for (const LidarPoint &p : s.lidar0.points) {
            if (!k.truth.valid(p.y, p.x)) continue;
            k.matches.u(p.y, p.x) = k.truth.u(p.y, p.x);
            k.matches.v(p.y, p.x) = k.truth.v(p.y, p.x);
            k.matches.d0(p.y, p.x) = p.disparity;
            k.matches.d1(p.y, p.x) = k.truth.d1(p.y, p.x);
            k.matches.valid(p.y, p.x) = 1;
        }
        return k;
    }();
    return c;
}

void synthetic_street_outliers_bounded(void **) {
    const Case &c = the_case();
    interpolation::InterpolationOptions o;
    o.num_threads = 2;
    const interpolation::InterpolationResult on = interpolation::RobustInterpolator(o).run(c.matches, c.scene.lidar0, c.scene.left0);
    o.use_lidar = false;
    const interpolation::InterpolationResult off = interpolation::RobustInterpolator(o).run(c.matches, c.scene.lidar0, c.scene.left0);
    const test::OutlierRates a = test::outlier_rates(on.dense, c.truth);
    const test::OutlierRates b = test::outlier_rates(off.dense, c.truth);
    std::printf("synthetic street, %d matches, %zu LiDAR: Interp+LiDAR D0 %.2f D1 %.2f Fl %.2f SF %.2f | "
                "Interp-only SF %.2f\n",
                cv::countNonZero(c.matches.valid), c.scene.lidar0.points.size(), a.d0, a.d1, a.fl, a.sf, b.sf);
    assert_true(a.d0 < 6.0 && a.d1 < 6.0 && a.fl < 6.0);
    assert_true(a.sf < 8.0);
    assert_true(a.sf <= b.sf + 0.25);
}

}  // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(synthetic_street_outliers_bounded),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
