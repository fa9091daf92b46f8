// SPDX-License-Identifier: MIT
#pragma once
// LiDAR points that the left camera cannot see.
//
// A LiDAR is mounted apart from the camera (on KITTI's car 0.27 m behind and 0.08 m above
// camera 2, 6 cm to its side), so it sees parts of the background that a nearer object hides
// from the camera. Projected into the left image, such a point lands on the nearer object, a few
// pixels inside its edge, with the background's disparity: the estimator would then anchor the
// object's depth (and its superpixel's plane) to the wrong surface. A point of disparity d counts
// as hidden when a point within a small window around it is much nearer, i.e. has a disparity
// above d * (1 + ratio) + margin.
// The window spans the few pixels the offset between the sensors shifts an edge across, and
// up and down most of the way to the next scan ring, where the nearer surface's own points are:
// its half height follows the input's ring spacing unless set (the lower quartile of the
// vertical gaps between the points of one image column: 5 px for a 64-beam scan in a KITTI-size
// image, 10 px for 32 beams, 19 px for 16). Points next to an edge but truly in view (the
// background just beside an object) go too; the interpolation fills them from their
// neighbours. Sparse inputs (the paper's ~88 points, tens of pixels apart) are left as they
// are: their windows hold no other point.
#include "core/lidar.hpp"

namespace lidarflow::lidar {

struct VisibilityFilterOptions {
    bool enabled = true;
    int half_width = 6;    // [px] window: (2 half_width + 1) x (2 half_height + 1) around a point
    // 0 = from the input: 0.7 x its ring spacing (above), in [1, kMaxAutoHalfHeight]; 4 when it
    // has too few points in common columns to tell.
    int half_height = 0;
    float ratio = 0.05f;   // a point is hidden by one nearer than d * (1 + ratio) + margin
    float margin = 1.0f;   // [px of disparity]

    // Throws Error(InvalidArgument) naming the first bad field: half sizes in [0, 64], ratio in
    // [0, 10], margin in [0, kMaxLidarDisparity] (all finite).
    void validate() const;
};

constexpr int kMaxAutoHalfHeight = 16;

// The half height half_height = 0 stands for on these points (see above); points outside their
// width x height are not counted.
int auto_half_height(const SparseLidar &points);

// The points of `in` that no point of their window hides, in their input order; width and
// height are kept. Of several points on one pixel, the nearest hides the others by the same rule.
// Returns `in` unchanged when !o.enabled. Throws Error(InvalidArgument) for bad options, and the
// errors of SparseLidar::validate (SizeMismatch is impossible here; InvalidArgument for a point
// outside the image or a disparity that is NaN or outside [0, kMaxLidarDisparity]). Pure
// function, thread-safe.
SparseLidar remove_hidden_points(const SparseLidar &in, const VisibilityFilterOptions &o);

}  // namespace lidarflow::lidar
