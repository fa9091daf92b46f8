// SPDX-License-Identifier: MIT
#pragma once
// Field comparisons shared by the suites that run the estimator on synthetic scenes.
#include <opencv2/core.hpp>

#include "core/maps.hpp"
#include "core/pixels.hpp"
#include "eval/metrics.hpp"
#include "synth/scene.hpp"

namespace lidarflow::test {

// The synthetic scene of `seed` at width x height, rendered on two threads.
inline synth::SynthScene render_scene(int width, int height, unsigned seed) {
    synth::SynthConfig c;
    c.width = width;
    c.height = height;
    c.seed = seed;
    c.threads = 2;
    return synth::render(c);
}

// Bit-for-bit equality of two images (core/pixels.hpp).
inline bool same_mat(const cv::Mat &a, const cv::Mat &b) { return pixel_identical(a, b); }

inline bool same_field(const SceneFlowField &a, const SceneFlowField &b) {
    return same_mat(a.u, b.u) && same_mat(a.v, b.v) && same_mat(a.d0, b.d0) && same_mat(a.d1, b.d1) &&
           same_mat(a.valid, b.valid) && same_mat(a.confidence, b.confidence);
}

// KITTI SF outliers [%] of f against the scene's occ ground truth (pixels with all three).
inline double sf_outliers(const synth::SynthScene &s, const SceneFlowField &f) {
    long n = 0, bad = 0;
    for (int y = 0; y < f.height(); ++y)
        for (int x = 0; x < f.width(); ++x) {
            if (s.disp0_occ(y, x) < 0 || s.disp1_occ(y, x) < 0 || !s.flow_occ.valid(y, x)) continue;
            ++n;
            bad += (eval::disparity_outlier(s.disp0_occ(y, x), f.d0(y, x)) ||
                    eval::disparity_outlier(s.disp1_occ(y, x), f.d1(y, x)) ||
                    eval::flow_outlier(s.flow_occ.u(y, x), s.flow_occ.v(y, x), f.u(y, x), f.v(y, x)))
                       ? 1
                       : 0;
        }
    return n ? 100.0 * bad / n : 100.0;
}

}  // namespace lidarflow::test
