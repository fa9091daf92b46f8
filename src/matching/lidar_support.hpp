// SPDX-License-Identifier: MIT
#pragma once
// LiDAR support windows and the disparity interval of constraint 2 (internal to matching).
#include <vector>

#include <opencv2/core.hpp>

namespace lidarflow::matching {

// Label image of size (height, width): at each pixel the index of the nearest point (Euclidean
// distance to the point's sub-pixel position) whose square window of half-size `radius`
// around its rounded position contains the pixel, or -1. Ties go to the lower index. Points
// outside the image are ignored. radius 0 labels the rounded point pixels only.
cv::Mat1i nearest_point_labels(const std::vector<cv::Point2f> &points, int width, int height,
                               int radius);

// Constraint 2: the disparity interval [lo, hi] around a LiDAR value (same units as value).
struct DisparityInterval {
    float lo = 0, hi = 0;
    float clamp(float d) const { return d < lo ? lo : (d > hi ? hi : d); }
    bool contains(float d) const { return d >= lo && d <= hi; }
};
DisparityInterval disparity_interval(float value, float abs_halfwidth, float rel_halfwidth);

// The d1 of a candidate whose d0 a LiDAR rule moved from d0_before to d0_after: shifted by the
// same amount when keep_change (the candidate keeps its disparity change d1 - d0), else as is.
inline float d1_after_d0_rule(float d1, float d0_before, float d0_after, bool keep_change) {
    return keep_change ? d1 + (d0_after - d0_before) : d1;
}

}  // namespace lidarflow::matching
