// SPDX-License-Identifier: MIT
#pragma once
// KITTI-style error images (the devkit's errorImage), for disparity and optical flow.
//
// Log colours: the error is normalised as n = min(e / 3, 20 e / |gt|), so n = 1 is exactly the
// KITTI outlier threshold (3 px and 5 %), and coloured by ten bands, blue (n < 1/16) through
// pale (n in [1/2, 1)) to dark red (n >= 16). Linear colours: grey = min(e, 5) / 5.
// Pixels valid only in the occluded ground truth (occ but not noc) are drawn at half
// brightness (log colours) or in red (linear), as the devkit does; pixels without ground
// truth are black. An estimate that is invalid where ground truth exists counts as an
// infinite error (worst band): fill holes first if the devkit's interpolation is wanted.
#include <opencv2/core.hpp>

#include "core/maps.hpp"

namespace lidarflow::viz {

struct ErrorImageOptions {
    bool log_colors = true;
    // The devkit paints each pixel as a 3x3 block so that sparse ground truth stays visible.
    // Off by default: on dense ground truth it only blurs.
    bool dilate = false;
};

// CV_8UC3 BGR error image of `est` against `gt_occ` (and `gt_noc`, which may be empty: then
// gt_occ is used for both). The result owns its pixels. Throws Error: InvalidArgument for
// empty inputs, SizeMismatch when the maps differ in size.
cv::Mat disparity_error_image(const DisparityMap &est, const DisparityMap &gt_occ, const DisparityMap &gt_noc = {},
                              const ErrorImageOptions &options = {});
cv::Mat flow_error_image(const FlowField &est, const FlowField &gt_occ, const FlowField &gt_noc = {},
                         const ErrorImageOptions &options = {});

// The colour (BGR) of normalised error n in the log scale; n = +inf gives the worst band.
cv::Vec3b log_error_color(double n);

}  // namespace lidarflow::viz
