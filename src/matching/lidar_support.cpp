// SPDX-License-Identifier: MIT
#include "matching/lidar_support.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/maps.hpp"

namespace lidarflow::matching {

cv::Mat1i nearest_point_labels(const std::vector<cv::Point2f> &points, int width, int height,
                               int radius) {
    cv::Mat1i labels = filled(height, width, -1);
    cv::Mat1f best = filled(height, width, std::numeric_limits<float>::infinity());
    for (int k = 0; k < static_cast<int>(points.size()); ++k) {
        const cv::Point2f p = points[k];
        const int cx = static_cast<int>(std::lround(p.x)), cy = static_cast<int>(std::lround(p.y));
        if (cx < 0 || cy < 0 || cx >= width || cy >= height) continue;
        for (int y = std::max(0, cy - radius); y <= std::min(height - 1, cy + radius); ++y)
            for (int x = std::max(0, cx - radius); x <= std::min(width - 1, cx + radius); ++x) {
                const float dx = static_cast<float>(x) - p.x, dy = static_cast<float>(y) - p.y;
                const float d2 = dx * dx + dy * dy;
                if (d2 < best(y, x)) {  // strict: ties keep the lower index
                    best(y, x) = d2;
                    labels(y, x) = k;
                }
            }
    }
    return labels;
}

DisparityInterval disparity_interval(float value, float abs_halfwidth, float rel_halfwidth) {
    const float hw = std::max(abs_halfwidth, rel_halfwidth * value);
    return {std::max(0.0f, value - hw), value + hw};
}

}  // namespace lidarflow::matching
