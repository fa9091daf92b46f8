// SPDX-License-Identifier: MIT
#pragma once
// Colour coding of disparity maps, in the KITTI devkit's style (disp_to_color.m): a piecewise
// linear map black -> blue -> red -> magenta -> green -> cyan -> yellow -> white over
// d / max_disp, so near (large disparity) is bright and far is dark.
#include <opencv2/core.hpp>

#include "core/maps.hpp"

namespace lidarflow::viz {

// CV_8UC3 BGR picture of `disp`, same size. Invalid (negative or NaN) pixels are black;
// disparities above max_disp saturate at white. max_disp <= 0: the largest valid disparity.
// The result owns its pixels. Throws Error(InvalidArgument) for an empty map or a non-finite
// max_disp.
cv::Mat disparity_to_color(const DisparityMap &disp, float max_disp = 0);

// The scale disparity_to_color uses: max_disp when > 0, else the largest valid disparity (1 when
// there is none). Throws Error(InvalidArgument) for a non-finite max_disp.
double disparity_color_scale(const DisparityMap &disp, float max_disp = 0);

// The colour of one valid disparity d at scale max_disp > 0 (d is clamped to [0, max_disp]).
cv::Vec3b disparity_color(double d, double max_disp);

}  // namespace lidarflow::viz
