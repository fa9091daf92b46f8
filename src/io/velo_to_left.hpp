// SPDX-License-Identifier: MIT
#pragma once
// The one transform a user of a KITTI-style rig needs for raw LiDAR points: Velodyne frame ->
// left (camera 2) rectified camera frame, i.e. the frame of lf_calibration_t.lidar_to_camera,
// in which the ideal pinhole K = P_rect_02(:, 0:3) with no offset projects the point.
//
// KITTI's chain is X_rect0 = R_rect_00 * Tr_velo_to_cam * X_velo and pixel = P_rect_02 * X_rect0,
// where P_rect_02 = K [I | t2] carries camera 2's offset in camera 0's rectified frame. So
//   velo_to_left = [I t2; 0 1] * [R_rect_00 0; 0 1] * Tr_velo_to_cam,  t2 = K^-1 P_rect_02(:, 3);
// then K * (velo_to_left * X) equals P_rect_02 * X_rect0 (same pixel, same depth w).
#include <opencv2/core.hpp>

#include "io/calib.hpp"

namespace lidarflow::io {

// Throws Error(InvalidArgument) for a non-finite input or a P_rect_02 whose left 3x3 is not an
// upper-triangular pinhole with fx, fy > 0.
cv::Matx44d velo_to_left_rect(const CamToCamCalib &calib, const cv::Matx44d &velo_to_cam);

}  // namespace lidarflow::io
