// SPDX-License-Identifier: MIT
#pragma once
// Stage 2a: the d0 of every match is compared with an SGM disparity of (I_l^0, I_r^0).
#include <opencv2/core.hpp>

#include "consistency/lidar_reference.hpp"
#include "consistency/options.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency {

// OpenCV StereoSGBM disparity of a rectified pair (8-bit, gray or BGR, same size and type).
// Returns a new map: disparity [px] where SGM found one, kInvalidDisparity where it rejected the
// pixel. Throws InvalidArgument for empty / non-8-bit images, images wider (with the left
// padding) or taller than 32767 px, or bad settings; SizeMismatch for images of different size
// or type.
DisparityMap compute_sgm_disparity(const cv::Mat &left, const cv::Mat &right, const SgmOptions &opt = {});

// Keeps the valid matches of `forward` whose |d0 - sgm| <= opt.sgm_max_diff. Never removed:
// LiDAR pixels and pixels inside a support window (lidar.in_window); pixels where sgm is
// invalid are kept or removed by opt.sgm_keep_unverified. Returns a new field (zeros where
// invalid); inputs are only read. Throws SizeMismatch when sizes differ, InvalidArgument on a
// non-finite value at a valid pixel or in sgm, or bad options.
SceneFlowField sgm_check(const SceneFlowField &forward, const DisparityMap &sgm, const LidarReference &lidar,
                         const ConsistencyOptions &opt);

}  // namespace lidarflow::consistency
