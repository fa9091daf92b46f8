// SPDX-License-Identifier: MIT
#pragma once
// The sparse LiDAR inputs of the paper (section "LiDAR-Flow Input Data"), built from KITTI
// ground truth:
//  - D0: disp_occ_0 (already a map in I_l^0), sparsified on a regular grid of 5x5 windows;
//  - D1: disp_occ_1 is the t1 disparity *warped into I_l^0*; a LiDAR at t1 would see it in
//    I_l^1, so every pixel p with a valid disparity and flow is de-warped ("splatted") to
//    round(p + flow(p)) in I_l^1, then sparsified the same way.
//
// Occlusion handling of the de-warp: (1) when several pixels land on one target the nearest
// (largest disparity) wins, as a beam stops at the first surface; (2) forward splatting leaves
// one-pixel gaps in surfaces that come closer (they grow in I_l^1), and a farther point can land
// in such a gap although a real beam would hit the nearer surface: a target whose 8-neighbourhood
// holds at least `gap_min_nearer` clearly nearer targets (disparity larger by more than
// max(1 px, 5 %)) is dropped. Targets outside the image are dropped (the point left the view).
// Holes are not filled: a LiDAR has no value there either, and the sampler only needs some
// measurement per 5x5 window.
//
// Non-correspondence (the paper: "the correspondences of the two sparse measurements are
// completely dissolved"): the D1 grid is shifted by half a step against the D0 grid, and a D1
// candidate is rejected when its de-warp source pixel in I_l^0 lies within the 5x5 window
// (Chebyshev distance <= 2) of any D0 sample; the window then takes its next-nearest
// candidate. So no D1 sample observes the surface point of a D0 sample or its immediate
// neighbours, and the matcher cannot read a scene-flow vector off a sample pair.
//
// Grid step: unless fixed by the caller, one step per frame is searched over [window, max(W,H)]
// and the one minimising |#D0 - N| + |#D1 - N| wins (ties: the smaller step). The paper quotes
// N = 88 as an average over the training set; the per-frame search gives about N on every frame
// regardless of how much of the image the ground truth covers.
#include <vector>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"
#include "core/maps.hpp"

namespace lidarflow::lidar {

struct DewarpOptions {
    int gap_min_nearer = 6;  // 1..8 nearer neighbours that make a target a gap; 9 disables
};

struct DewarpResult {
    DisparityMap disp;  // t1 disparities in I_l^1; kInvalidDisparity where none
    cv::Mat2i source;   // per target, the pixel (x, y) of I_l^0 it came from; (-1, -1) where none
    int moved = 0;      // pixels with valid disparity and flow
    int outside = 0;    // ... that landed outside the image
    int collisions = 0; // ... that lost against a nearer one on the same target
    int gaps = 0;       // targets dropped as gaps in a nearer surface
};

// De-warps disp1 (t1 disparity in I_l^0) through flow into I_l^1. The result owns its maps.
// Throws Error: InvalidArgument for empty input, a valid disparity or flow that is not finite,
// or gap_min_nearer outside 1..9; SizeMismatch when the maps differ in size.
DewarpResult dewarp_to_t1(const DisparityMap &disp1, const FlowField &flow, const DewarpOptions &opt = {});

struct PaperProtocolOptions {
    int target_points = 88;  // N per map, used when step == 0
    int step = 0;            // fixed grid step (>= window); 0 = search per frame
    int window = 5;          // odd
    // Shift of both grids against the paper's origin (grid_spec), as a fraction of the step in
    // [0, 1) per axis, rounded to whole pixels. The paper fixes one placement; with ~88 points it
    // decides which surfaces get a measurement at all, and on the shared KITTI frames a shift of
    // one pixel moves the final SF by about as much as a change of method
    // (docs/experiments/lidar-placement.md), so other placements tell how much a result owes
    // to that one draw.
    cv::Point2d phase{0, 0};
    DewarpOptions dewarp;
};

struct PaperSamples {
    SparseLidar d0;                     // in I_l^0
    SparseLidar d1;                     // in I_l^1
    std::vector<cv::Point> d1_source;   // per d1 point, its de-warp source pixel in I_l^0
    int step = 0;                       // grid step used for both maps
    DewarpResult dewarp;                // the dense de-warped D1 and its statistics
};

// Runs the protocol on ground-truth maps of one frame (disp0 = disp_occ_0, disp1 =
// disp_occ_1, flow = flow_occ). The result owns everything. Throws Error: InvalidArgument for
// empty input, non-finite valid values, target_points < 1, an even window, 0 < step < window,
// or a phase outside [0, 1); SizeMismatch when the maps differ in size.
PaperSamples sample_paper_protocol(const DisparityMap &disp0, const DisparityMap &disp1, const FlowField &flow,
                                   const PaperProtocolOptions &opt = {});

// The grid phase of placement j (PaperProtocolOptions::phase): (0, 0), the paper's, for j = 0,
// then a low-discrepancy sequence over [0, 1)^2. Throws InvalidArgument for j < 0.
cv::Point2d placement_phase(int placement);

}  // namespace lidarflow::lidar
