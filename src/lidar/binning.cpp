// SPDX-License-Identifier: MIT
#include "lidar/binning.hpp"

#include <cstdint>
#include <vector>

namespace lidarflow::lidar {

SparseLidar bin_points(const SparseLidar &lidar, int cell) {
    if (cell <= 1 || lidar.points.empty()) return lidar;
    const int cw = (lidar.width + cell - 1) / cell, ch = (lidar.height + cell - 1) / cell;
    std::vector<int> best(static_cast<size_t>(cw) * ch, -1);
    auto dist2 = [&](const LidarPoint &p) {  // to the cell's centre, in quarter pixels squared
        const int dx = 2 * (p.x % cell) - (cell - 1), dy = 2 * (p.y % cell) - (cell - 1);
        return dx * dx + dy * dy;
    };
    for (size_t i = 0; i < lidar.points.size(); ++i) {
        const LidarPoint &p = lidar.points[i];
        int &b = best[static_cast<size_t>(p.y / cell) * cw + p.x / cell];
        if (b < 0) {
            b = static_cast<int>(i);
            continue;
        }
        const LidarPoint &q = lidar.points[static_cast<size_t>(b)];
        const int dp = dist2(p), dq = dist2(q);
        if (dp < dq || (dp == dq && p.disparity > q.disparity)) b = static_cast<int>(i);
    }
    std::vector<uint8_t> keep(lidar.points.size(), 0);
    for (int b : best)
        if (b >= 0) keep[static_cast<size_t>(b)] = 1;
    SparseLidar out{lidar.width, lidar.height, {}};
    for (size_t i = 0; i < lidar.points.size(); ++i)
        if (keep[i]) out.points.push_back(lidar.points[i]);
    return out;
}

}  // namespace lidarflow::lidar
