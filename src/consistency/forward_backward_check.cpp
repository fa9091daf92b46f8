// SPDX-License-Identifier: MIT
#include "consistency/forward_backward_check.hpp"

#include <cmath>
#include <limits>

#include "consistency/steps.hpp"
#include "consistency/validate.hpp"
#include "core/error.hpp"
#include "core/maps.hpp"
#include "core/rounding.hpp"

namespace lidarflow::consistency {

namespace {

struct BackwardSample {
    float u, v, d0, d1;
};

// Guards the float -> int conversions below against absurd (but finite) displacements.
bool inside(const SceneFlowField &b, float qx, float qy) {
    return qx > -1.0f && qy > -1.0f && qx < static_cast<float>(b.width()) && qy < static_cast<float>(b.height());
}

bool sample_nearest(const SceneFlowField &b, float qx, float qy, BackwardSample &s) {
    if (!inside(b, qx, qy)) return false;
    int x, y;
    if (!nearest_inside(qx, qy, b.width(), b.height(), x, y) || !b.valid(y, x)) return false;
    s = {b.u(y, x), b.v(y, x), b.d0(y, x), b.d1(y, x)};
    return true;
}

// Bilinear only where all four neighbours are valid: interpolating towards an invalid pixel
// would invent values, so such q fall back to the nearest neighbour.
bool sample_bilinear(const SceneFlowField &b, float qx, float qy, BackwardSample &s) {
    if (!inside(b, qx, qy)) return false;
    const int x0 = static_cast<int>(std::floor(qx)), y0 = static_cast<int>(std::floor(qy));
    if (x0 >= 0 && y0 >= 0 && x0 + 1 < b.width() && y0 + 1 < b.height() && b.valid(y0, x0) &&
        b.valid(y0, x0 + 1) && b.valid(y0 + 1, x0) && b.valid(y0 + 1, x0 + 1)) {
        const float ax = qx - x0, ay = qy - y0;
        auto lerp = [&](const cv::Mat1f &m) {
            return (1 - ay) * ((1 - ax) * m(y0, x0) + ax * m(y0, x0 + 1)) +
                   ay * ((1 - ax) * m(y0 + 1, x0) + ax * m(y0 + 1, x0 + 1));
        };
        s = {lerp(b.u), lerp(b.v), lerp(b.d0), lerp(b.d1)};
        return true;
    }
    return sample_nearest(b, qx, qy, s);
}

}  // namespace

ForwardBackwardResult detail::forward_backward_check(const SceneFlowField &forward, const SceneFlowField &backward,
                                                     const LidarReference &lidar, const CheckedOptions &checked) {
    const ConsistencyOptions &opt = checked.get();
    detail::check_field(forward, "forward");
    detail::check_field(backward, "backward");
    const int h = forward.height(), w = forward.width();
    detail::check_size(backward.u, h, w, "backward field");
    detail::check_size(lidar.is_lidar, h, w, "LiDAR mask");

    ForwardBackwardResult r;
    // Each row cleared where it is filled, below.
    r.field = SceneFlowField::uninitialized(w, h);
    r.error.create(h, w);
    r.lidar_motion_unreliable.create(h, w);
    const bool bilinear = opt.fb_lookup == BackwardLookup::Bilinear;
    const int radius = opt.fb_search_radius;

    // Rows are independent: each pixel writes only its own outputs.
#pragma omp parallel for schedule(static) num_threads(opt.threads)
    for (int y = 0; y < h; ++y) {
        r.field.clear_row(y);
        std::fill(r.error[y], r.error[y] + w, std::numeric_limits<float>::infinity());
        std::fill(r.lidar_motion_unreliable[y], r.lidar_motion_unreliable[y] + w, uchar{0});
        for (int x = 0; x < w; ++x) {
            if (!forward.valid(y, x)) continue;
            const bool is_lidar = lidar.is_lidar(y, x) != 0;
            const float u = forward.u(y, x), v = forward.v(y, x);
            // The best round trip over B's pixels q + (dx, dy): a pass beats a failure, then the
            // lower error wins (first in raster order on ties).
            bool ok = false;
            for (int dy = -radius; dy <= radius; ++dy)
                for (int dx = -radius; dx <= radius; ++dx) {
                    BackwardSample s{};
                    const float qx = x + u + dx, qy = y + v + dy;
                    if (!(bilinear ? sample_bilinear(backward, qx, qy, s) : sample_nearest(backward, qx, qy, s)))
                        continue;
                    // Coming back from q + (dx, dy) must land on p: (u + dx, v + dy) + (u_b, v_b) = 0.
                    // sqrt, not hypot: the fields are finite and bounded (no overflow to guard
                    // against), and hypotf was ~1 % of a frame's samples for (2r + 1)^2 lookups.
                    const float fx = u + dx + s.u, fy = v + dy + s.v;
                    const float e_flow = std::sqrt(fx * fx + fy * fy);
                    const float e_d0 = is_lidar ? 0.0f : std::fabs(forward.d0(y, x) - s.d1);
                    const float e_d1 = std::fabs(forward.d1(y, x) - s.d0);
                    const bool pass = e_flow <= opt.fb_max_flow && e_d0 <= opt.fb_max_d0 && e_d1 <= opt.fb_max_d1;
                    const float e = e_flow / opt.fb_max_flow + e_d0 / opt.fb_max_d0 + e_d1 / opt.fb_max_d1;
                    if ((pass && !ok) || (pass == ok && e < r.error(y, x))) {
                        r.error(y, x) = e;
                        ok = pass;
                    }
                }
            if (ok || (is_lidar && opt.keep_unreliable_lidar)) detail::keep_match(r.field, forward, y, x);
            if (is_lidar && !ok) r.lidar_motion_unreliable(y, x) = 1;
        }
    }
    return r;
}

ForwardBackwardResult forward_backward_check(const SceneFlowField &forward, const SceneFlowField &backward,
                                             const LidarReference &lidar, const ConsistencyOptions &opt) {
    return detail::forward_backward_check(forward, backward, lidar, detail::CheckedOptions(opt));
}

}  // namespace lidarflow::consistency
