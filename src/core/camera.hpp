// SPDX-License-Identifier: MIT
#pragma once
// Rectified stereo camera model shared by every stage.
namespace lidarflow {

struct StereoCamera {
    double fx = 0, fy = 0;  // focal lengths [px]
    double cx = 0, cy = 0;  // principal point [px]
    double baseline = 0;    // distance between the rectified left and right centres [m]

    bool valid() const { return fx > 0 && fy > 0 && baseline > 0; }
    // d = fx * B / z for a point at depth z [m] in the left rectified camera.
    double disparity_from_depth(double z) const { return fx * baseline / z; }
    double depth_from_disparity(double d) const { return fx * baseline / d; }
};

}  // namespace lidarflow
