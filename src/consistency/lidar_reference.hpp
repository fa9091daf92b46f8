// SPDX-License-Identifier: MIT
#pragma once
// The D_l^0 measurements as the consistency stages see them: which pixels are LiDAR pixels
// (never filtered, reference values of the clustering) and which lie in a support window
// (exempt from the SGM check of stage 2a only).
#include <opencv2/core.hpp>

#include "core/lidar.hpp"

namespace lidarflow::consistency {

struct LidarReference {
    cv::Mat1b is_lidar;      // 1 at a D_l^0 pixel
    cv::Mat1b in_window;     // 1 inside any support window (LiDAR pixels included)
    DisparityMap disparity;  // the LiDAR d0 at is_lidar pixels, kInvalidDisparity elsewhere
    int count = 0;           // number of distinct LiDAR pixels; 0 = image-only mode

    bool image_only() const { return count == 0; }

    // Builds the reference for an image of width x height. A lidar without points is the
    // image-only mode (its own width/height may then be 0). The result owns its maps. Throws
    // InvalidArgument for a non-positive size, an even or non-positive window, a point outside
    // the image or with a non-finite or negative disparity; SizeMismatch when a non-empty lidar
    // was aligned to an image of another size.
    static LidarReference build(const SparseLidar &lidar, int width, int height, int window);
};

}  // namespace lidarflow::consistency
