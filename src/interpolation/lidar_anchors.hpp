// SPDX-License-Identifier: MIT
#pragma once
// Association of superpixels with LiDAR (paper Fig. 5): each superpixel takes the LiDAR
// measurement closest to its centre for geometry and the closest LiDAR match (a LiDAR pixel
// whose u, v, d1 survived) for motion; a point becomes the superpixel's anchor when it lies
// inside the superpixel or within `max_distance` of its centre.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "interpolation/superpixels.hpp"

namespace lidarflow::interpolation {

struct LidarAnchors {
    std::vector<int> geometry;  // seed index per superpixel, -1 = centre anchor
    std::vector<int> motion;
    static LidarAnchors none(int count) { return {std::vector<int>(count, -1), std::vector<int>(count, -1)}; }
};

// pos/is_lidar/has_motion describe the seeds (same length); pos must lie inside sp.labels.
// Ties in distance go to the lower seed index (deterministic). Does not throw on valid input.
LidarAnchors associate_lidar(const Superpixels &sp, const std::vector<cv::Point> &pos,
                             const std::vector<uint8_t> &is_lidar, const std::vector<uint8_t> &has_motion,
                             float max_distance);

}  // namespace lidarflow::interpolation
