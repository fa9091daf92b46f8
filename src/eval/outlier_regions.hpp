// SPDX-License-Identifier: MIT
#pragma once
// Where a dense estimate's scene flow outliers are: the devkit's scores (occ ground truth, holes
// filled) restricted to image regions, so that a change to the method can be aimed at a measured
// share of the outliers instead of the total alone. Families of regions, each a partition of the
// scene flow ground-truth pixels:
//  - "at t1": the pixel's point leaves the image at t1 (its ground-truth flow ends outside), is
//    occluded (in the occ but not in all three noc ground truths: hidden in the right image at
//    t0 or in an image at t1), or is visible;
//  - "LiDAR": distance to the nearest LiDAR seed pixel, <= 7 px (inside the 15 px support
//    windows of the paper's Table II), 8-30 px, > 30 px (only when a seed map is given);
//  - "depth": ground-truth d0 >= 40 px (nearer than ~10 m on KITTI), 10-40 px, < 10 px (farther
//    than ~40 m);
//  - "objects": KITTI's obj_map (0 = background, else a foreground object, the devkit's bg/fg
//    split), when one is given.
#include <string>
#include <vector>

#include "eval/metrics.hpp"

namespace lidarflow::eval {

struct OutlierRegion {
    std::string family, name;  // e.g. "at t1", "occluded"; the first region is ("all", "all")
    ComponentScores scores;    // Filled-mode counts over the region's pixels, additive over frames
};

struct OutlierBreakdown {
    std::vector<OutlierRegion> regions;
    // Adds another frame's counts region by region (regions missing here are appended).
    OutlierBreakdown &operator+=(const OutlierBreakdown &o);
};

// The breakdown of one frame. lidar_seeds and objects may be null (those families are left
// out); gt.has_noc false leaves "occluded" out of "at t1". Inputs are only read. Throws as
// evaluate_frame does, SizeMismatch for an objects map of another size.
OutlierBreakdown outlier_breakdown(const FrameGroundTruth &gt, const Estimate &est, const DisparityMap *lidar_seeds,
                                   const cv::Mat1b *objects);

// A text table: per region its share of the SF pixels, its SF outlier rate, its share of all SF
// outliers and its D0 / D1 / Fl outlier rates. `compare` (may be null) is the same breakdown of
// another estimate (e.g. image-only), printed as one more SF column named compare_name.
std::string format_outlier_breakdown(const OutlierBreakdown &b, const OutlierBreakdown *compare = nullptr,
                                     const std::string &compare_name = "");

}  // namespace lidarflow::eval
