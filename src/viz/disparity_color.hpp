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

}  // namespace lidarflow::viz
