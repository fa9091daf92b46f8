// SPDX-License-Identifier: MIT
#pragma once
// Sparse LiDAR measurements aligned to one left image: a list of (pixel, disparity).
#include <string>
#include <vector>

#include "core/maps.hpp"

namespace lidarflow {

struct LidarPoint {
    int x = 0, y = 0;      // pixel in the image the scan is aligned to
    float disparity = 0;   // d = fx * B / z [px]
};
inline bool operator==(const LidarPoint &a, const LidarPoint &b) {
    return a.x == b.x && a.y == b.y && a.disparity == b.disparity;
}

struct SparseLidar {
    int width = 0, height = 0;  // size of the image the points live in
    std::vector<LidarPoint> points;

    // Dense map with the points' disparities and kInvalidDisparity elsewhere. Of several points
    // on one pixel the largest disparity (the nearest, visible surface) wins, whatever their order.
    DisparityMap to_map() const;
    // Every valid pixel of a disparity map becomes a point (row-major order).
    static SparseLidar from_map(const DisparityMap &map);
    // Checks that the points fit images of w x h (sizes must agree unless there are no points)
    // with disparities in [0, kMaxLidarDisparity] (core/limits.hpp). Throws SizeMismatch /
    // InvalidArgument, the message starting with `what` (e.g. "MatchInput: lidar0").
    void validate(int w, int h, const std::string &what) const;
};

}  // namespace lidarflow
