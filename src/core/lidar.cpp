// SPDX-License-Identifier: MIT
#include "core/lidar.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "core/maps.hpp"

namespace lidarflow {

DisparityMap SparseLidar::to_map() const {
    require(width > 0 && height > 0, ErrorCode::InvalidArgument, "SparseLidar has no image size");
    DisparityMap map = filled(height, width, kInvalidDisparity);
    for (const LidarPoint &p : points) {
        require(p.x >= 0 && p.y >= 0 && p.x < width && p.y < height, ErrorCode::InvalidArgument,
                "LiDAR point outside the image");
        map(p.y, p.x) = std::max(map(p.y, p.x), p.disparity);
    }
    return map;
}

void SparseLidar::validate(int w, int h, const std::string &what) const {
    if (points.empty()) return;
    require(width == w && height == h, ErrorCode::SizeMismatch,
            what + " is " + std::to_string(width) + "x" + std::to_string(height) + " but the images are " +
                std::to_string(w) + "x" + std::to_string(h));
    for (const LidarPoint &p : points) {
        require(p.x >= 0 && p.y >= 0 && p.x < w && p.y < h, ErrorCode::InvalidArgument,
                [&] { return what + " has a point outside the image"; });
        // Negated so that NaN fails as well.
        require(p.disparity >= 0.0f && p.disparity <= kMaxLidarDisparity, ErrorCode::InvalidArgument, [&] {
            return what + " has a disparity of " + std::to_string(p.disparity) + " px at (" + std::to_string(p.x) +
                   ", " + std::to_string(p.y) + "), outside [0, " + std::to_string(static_cast<int>(kMaxLidarDisparity)) +
                   "]";
        });
    }
}

SparseLidar SparseLidar::from_map(const DisparityMap &map) {
    SparseLidar out;
    out.width = map.cols;
    out.height = map.rows;
    for (int y = 0; y < map.rows; ++y)
        for (int x = 0; x < map.cols; ++x)
            if (disparity_valid(map(y, x))) out.points.push_back({x, y, map(y, x)});
    return out;
}

}  // namespace lidarflow
