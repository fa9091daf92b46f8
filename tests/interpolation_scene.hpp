// SPDX-License-Identifier: MIT
#pragma once
// Exactly piecewise-planar synthetic scene for the interpolation suites: four regions with
// sharp colour boundaries whose u, v, d0, d1 fields are affine in (x, y), sparse matches
// sampled from them (with gross outliers), and KITTI-style outlier rates of an estimate.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "motion/ego_motion.hpp"

namespace lidarflow::test {

struct Affine4 {
    // value = a x + b y + c for u, v, d0, d1
    float a[4], b[4], c[4];
    float at(int k, float x, float y) const { return a[k] * x + b[k] * y + c[k]; }
};

struct PlanarScene {
    cv::Mat image;        // CV_8UC3
    cv::Mat1b region;     // region id per pixel
    SceneFlowField truth; // dense, valid everywhere
};

// Small deterministic generator (tests must be reproducible).
struct TestRng {
    uint64_t s;
    explicit TestRng(uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ull + 0x1234567ull) {}
    uint64_t next() {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        return s;
    }
    double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
};

inline PlanarScene make_planar_scene(int w = 320, int h = 160) {
    // 0 background, 1 ground, 2 box, 3 disc; colours far apart so edges are strong.
    static const Affine4 regions[4] = {
        {{0.005f, 0.0f, 0.01f, 0.01f}, {0.0f, 0.0f, 0.0f, 0.0f}, {2.0f, 0.0f, 8.0f, 7.5f}},
        {{0.03f, 0.0f, 0.0f, 0.0f}, {0.0f, 0.04f, 0.25f, 0.27f}, {-4.8f, -1.4f, -5.0f, -4.0f}},
        {{0.0f, 0.0f, 0.02f, 0.02f}, {0.01f, 0.0f, -0.01f, -0.01f}, {-6.0f, 1.0f, 20.0f, 22.0f}},
        {{0.0f, 0.02f, -0.05f, 0.0f}, {0.0f, 0.0f, 0.0f, 0.0f}, {5.0f, -2.0f, 30.0f, 28.0f}},
    };
    static const cv::Vec3b colour[4] = {{200, 160, 120}, {90, 90, 90}, {40, 40, 200}, {60, 200, 60}};
    PlanarScene s;
    s.image.create(h, w, CV_8UC3);
    s.region.create(h, w);
    s.truth = SceneFlowField::zeros(w, h);
    const float sx = w / 320.0f, sy = h / 160.0f;
    TestRng rng(7);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            int r = y < 60 * sy ? 0 : 1;
            if (x >= 200 * sx && x < 260 * sx && y >= 40 * sy && y < 120 * sy) r = 2;
            const float dx = x - 90 * sx, dy = y - 100 * sy;
            if (dx * dx + dy * dy < 25 * 25 * sx * sy) r = 3;
            s.region(y, x) = static_cast<uint8_t>(r);
            const int noise = static_cast<int>(rng.next() % 21) - 10;  // mild texture
            for (int k = 0; k < 3; ++k)
                s.image.at<cv::Vec3b>(y, x)[k] = cv::saturate_cast<uint8_t>(colour[r][k] + noise);
            // Fields defined on the 320 x 160 layout, scaled with it (disparities stay >= 5).
            const Affine4 &m = regions[r];
            const float lx = x / sx, ly = y / sy;
            s.truth.u(y, x) = m.at(0, lx, ly);
            s.truth.v(y, x) = m.at(1, lx, ly);
            s.truth.d0(y, x) = m.at(2, lx, ly);
            s.truth.d1(y, x) = m.at(3, lx, ly);
            s.truth.valid(y, x) = 1;
            s.truth.confidence(y, x) = 1;
        }
    return s;
}

// Copies the truth at a random `density` share of the pixels; `outliers` of them get every
// component shifted by 5..30 px.
inline SceneFlowField sample_matches(const SceneFlowField &truth, double density, double outliers, uint64_t seed) {
    SceneFlowField m = SceneFlowField::zeros(truth.width(), truth.height());
    TestRng rng(seed);
    for (int y = 0; y < truth.height(); ++y)
        for (int x = 0; x < truth.width(); ++x) {
            if (rng.uniform() >= density) continue;
            m.u(y, x) = truth.u(y, x);
            m.v(y, x) = truth.v(y, x);
            m.d0(y, x) = truth.d0(y, x);
            m.d1(y, x) = truth.d1(y, x);
            m.valid(y, x) = 1;
            m.confidence(y, x) = 1;
            if (rng.uniform() < outliers) {
                auto off = [&] { return static_cast<float>((rng.uniform() < 0.5 ? -1 : 1) * (5 + 25 * rng.uniform())); };
                m.u(y, x) += off();
                m.v(y, x) += off();
                m.d0(y, x) = std::max(0.0f, m.d0(y, x) + off());
                m.d1(y, x) = std::max(0.0f, m.d1(y, x) + off());
            }
        }
    return m;
}

struct OutlierRates {
    double d0 = 0, d1 = 0, fl = 0, sf = 0;  // percent
    double epe_d0 = 0, epe_fl = 0;         // mean absolute error [px]
};

// KITTI criterion (> 3 px and > 5 % of the truth) over the pixels where truth.valid and
// (optional) mask are set.
inline OutlierRates outlier_rates(const SceneFlowField &est, const SceneFlowField &truth,
                                  const cv::Mat1b &mask = cv::Mat1b()) {
    OutlierRates r;
    double n = 0;
    auto bad = [](float e, float g) { return e > 3.0f && e > 0.05f * std::fabs(g); };
    for (int y = 0; y < truth.height(); ++y)
        for (int x = 0; x < truth.width(); ++x) {
            if (!truth.valid(y, x) || (!mask.empty() && !mask(y, x))) continue;
            const float e0 = std::fabs(est.d0(y, x) - truth.d0(y, x));
            const float e1 = std::fabs(est.d1(y, x) - truth.d1(y, x));
            const float ef = std::hypot(est.u(y, x) - truth.u(y, x), est.v(y, x) - truth.v(y, x));
            const bool b0 = bad(e0, truth.d0(y, x)), b1 = bad(e1, truth.d1(y, x));
            const bool bf = bad(ef, std::hypot(truth.u(y, x), truth.v(y, x)));
            n += 1;
            r.d0 += b0, r.d1 += b1, r.fl += bf, r.sf += (b0 || b1 || bf);
            r.epe_d0 += e0, r.epe_fl += ef;
        }
    if (n > 0) {
        r.d0 *= 100 / n, r.d1 *= 100 / n, r.fl *= 100 / n, r.sf *= 100 / n;
        r.epe_d0 /= n, r.epe_fl /= n;
    }
    return r;
}

// Exact (x, y, d0) -> (d1, u, v) samples of a known motion, for the ego-motion fits.
struct MotionSamples {
    std::vector<float> x, y, d0, d1, u, v;
};

// Largest prediction errors of model m on samples p: d1 [px] and flow end point [px].
inline void max_errors(const motion::EgoMotion &m, const MotionSamples &p, double &e_d1, double &e_fl) {
    e_d1 = e_fl = 0;
    for (size_t i = 0; i < p.x.size(); ++i) {
        float d1, u, v;
        m.predict(p.x[i], p.y[i], p.d0[i], d1, u, v);
        e_d1 = std::max(e_d1, static_cast<double>(std::fabs(d1 - p.d1[i])));
        e_fl = std::max(e_fl, std::hypot(static_cast<double>(u - p.u[i]), static_cast<double>(v - p.v[i])));
    }
}

}  // namespace lidarflow::test
