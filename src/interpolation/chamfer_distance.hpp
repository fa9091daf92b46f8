// SPDX-License-Identifier: MIT
#pragma once
// cv::distanceTransform(DIST_L2, 3x3 mask) at single pixels. OpenCV's two raster passes give every
// pixel its shortest 8-connected path to a zero pixel, steps weighted 0.955 along a row or column
// and 1.3693 across, in 16.16 fixed point; on an unobstructed grid that path is the closed form
// below, so a pixel's value needs only the zero pixels of the window that can beat a bound, not
// two passes over the whole map.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include <opencv2/core.hpp>

namespace lidarflow::interpolation {

struct ChamferMask3 {
    // OpenCV's CV_FLT_TO_FIX(metric, 16) of its DIST_L2 3x3 metrics (0.955, 1.3693).
    static constexpr uint64_t kStraight = 62587, kDiagonal = 89738;
    static constexpr float kScale = 1.0f / 65536.0f;

    // The distance from (x, y) to the nearest zero pixel of `mask` that lies within `reach`
    // pixels along both axes, as cv::distanceTransform computes it there (+inf when none does).
    // Every zero pixel farther along an axis is at least (reach + 1) * 0.955 px away.
    static float near(const cv::Mat1b &mask, int x, int y, int reach) {
        uint64_t best = std::numeric_limits<uint64_t>::max();
        const int y0 = std::max(0, y - reach), y1 = std::min(mask.rows - 1, y + reach);
        const int x0 = std::max(0, x - reach), x1 = std::min(mask.cols - 1, x + reach);
        for (int yy = y0; yy <= y1; ++yy) {
            const uchar *row = mask[yy];
            const uint64_t ay = static_cast<uint64_t>(std::abs(yy - y));
            for (int xx = x0; xx <= x1; ++xx) {
                if (row[xx]) continue;
                const uint64_t ax = static_cast<uint64_t>(std::abs(xx - x));
                const uint64_t lo = std::min(ax, ay), hi = std::max(ax, ay);
                best = std::min(best, kDiagonal * lo + kStraight * (hi - lo));
            }
        }
        return best == std::numeric_limits<uint64_t>::max() ? std::numeric_limits<float>::infinity()
                                                             : static_cast<float>(best) * kScale;
    }

    // The reach within which every zero pixel closer than `limit` (>= 0) lies; at most 2^20.
    static int reach_below(float limit) {
        return static_cast<int>(std::ceil(std::min(limit, 1e6f) / (static_cast<float>(kStraight) * kScale)));
    }
};

}  // namespace lidarflow::interpolation
