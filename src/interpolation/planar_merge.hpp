// SPDX-License-Identifier: MIT
#pragma once
// Merging a dense scan's small superpixels where they follow no depth boundary. A dense scan gets
// small superpixels so that depth boundaries fall between them; on the road, walls and other
// planes, and where the scan does not reach, that only multiplies stage 4's per-superpixel
// work. Merged back to at most the sparse size there, the boundaries keep their small ones.
#include <vector>

#include <opencv2/core.hpp>

#include "interpolation/superpixels.hpp"

namespace lidarflow::interpolation {

struct PlanarMergeOptions {
    float tolerance = 0.0f;  // largest |disparity - plane| of a merged region's points [px]; 0 = none
    bool unseen = false;     // also merge superpixels the points do not reach
    int max_area = 0;        // largest merged region [px]; <= 0 = off
    int min_points = 4;      // LiDAR points a superpixel needs to take part (>= 3)
    int threads = 1;         // for the merged superpixels' statistics; the result does not depend on it
};

// Superpixels of `sp` merged, greedily in label order over the adjacency (deterministic), while
// the union stays within max_area pixels, where
//  - both sides hold >= min_points of the points (pixel pos[i], disparity disparity[i]) and a
//    least-squares plane d = a x + b y + c through the union's points fits each within
//    `tolerance` (the road, walls: no depth boundary between them), or
//  - with `unseen`, neither side nor any of their neighbours holds a point (the image above
//    the scan: no boundary for small superpixels to follow).
// Labels are renumbered 0 .. count-1 in order of their smallest old label, with centroids,
// anchors and adjacency recomputed, and `parts` set to the superpixels merged into each.
// Points outside the image or with a non-finite disparity are ignored. Returns `sp` unchanged
// when off (tolerance 0 and not unseen, or max_area <= 0). Throws Error(InvalidArgument) on
// pos / disparity of different lengths or options out of range.
Superpixels merge_planar_superpixels(const Superpixels &sp, const std::vector<cv::Point> &pos,
                                     const std::vector<float> &disparity, const PlanarMergeOptions &options);

}  // namespace lidarflow::interpolation
