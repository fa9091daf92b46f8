// SPDX-License-Identifier: MIT
#pragma once
// Every threshold of stages 2-3 (paper: "LiDAR-Supported Consistency Check" and the
// sparsification opening "LiDAR-Supported Robust Interpolation"). Defaults were measured on the
// two shared KITTI 2015 frames (see docs/ARCHITECTURE.md, "Consistency check"); all distances
// are in pixels of the full-resolution left image I_l^0.
namespace lidarflow::consistency {

// OpenCV StereoSGBM settings for the reference disparity of stage 2a.
struct SgmOptions {
    int num_disparities = 128;  // search range [0, num_disparities); multiple of 16
    int block_size = 5;         // odd; P1 = 8*c*b^2, P2 = 32*c*b^2 (c = image channels)
    int uniqueness_ratio = 10;  // [%] margin of the best cost over the second best
    int disp12_max_diff = 1;    // left-right check tolerance [px]; < 0 disables it
    int speckle_window = 100;   // connected regions smaller than this become invalid; 0 = off
    int speckle_range = 2;      // disparity step [px] that splits speckle regions
    bool full_dp = false;       // true: MODE_HH (8 paths, slow); false: MODE_SGBM_3WAY
    // Pads the left border by num_disparities so that the leftmost columns also get a
    // disparity (searched only over the part of the range that stays inside I_r^0); without it
    // those columns give no verdict.
    bool pad_left_border = true;
};

enum class BackwardLookup {
    Nearest,   // B at round(q): never mixes two surfaces across a motion boundary
    Bilinear,  // B interpolated at q when its four neighbours are valid, else Nearest
};

struct ConsistencyOptions {
    int threads = 1;  // OpenMP threads of the per-pixel checks; results do not depend on it
    // --- LiDAR (ignored in image-only mode, i.e. when the SparseLidar has no points) ---
    int support_window = 15;  // side of the square window around each D_l^0 pixel (odd, >= 1)

    // --- stage 2a: d0 against the SGM disparity of (I_l^0, I_r^0) ---
    float sgm_max_diff = 2.0f;  // remove a match when |d0 - d_sgm| exceeds this [px]
    // Where SGM has no disparity (left-right / uniqueness / speckle rejected) there is no
    // verdict: true keeps the match, false removes it. Measured: the kept ones had ~25 % d0
    // outliers on KITTI (image matching fails where SGM does), so they are removed.
    bool sgm_keep_unverified = false;
    SgmOptions sgm;

    // --- stage 2b: forward-backward round trip, q = p + (u, v) looked up in B ---
    float fb_max_flow = 1.5f;  // |(u, v) + (u_b, v_b)(q)| [px]
    float fb_max_d0 = 1.5f;    // |d0 - d1_b(q)| [px]
    float fb_max_d1 = 1.5f;    // |d1 - d0_b(q)| [px]
    BackwardLookup fb_lookup = BackwardLookup::Nearest;
    // B is searched in the (2r+1)^2 pixels around q for the best round trip (see
    // forward_backward_check.hpp); 1 matches the matcher's 3 px seed grid, 0 = q only.
    int fb_search_radius = 1;
    // A LiDAR pixel is never removed for its d0, but its (u, v, d1) are checked in 2b (paper).
    // A SceneFlowField cannot hold a d0 without (u, v, d1), so when they fail: false removes the
    // match from the fields (flagged in lidar_motion_unreliable; the measurement itself stays in
    // the SparseLidar for the interpolation), true keeps it with the failed motion (then every
    // consumer must honour the flag). Measured on KITTI: 119 of 123 flagged LiDAR matches were
    // SF outliers.
    bool keep_unreliable_lidar = false;

    // --- clustering after 2a and after 2b ---
    // Two neighbouring matches join one cluster when |du|, |dv| <= cluster_max_flow_step and
    // |dd0|, |dd1| <= cluster_max_disp_step.
    float cluster_max_flow_step = 1.5f;
    float cluster_max_disp_step = 1.0f;
    int cluster_min_size = 100;        // clusters with fewer matches are removed ...
    bool keep_lidar_clusters = true;   // ... unless they hold a trusted LiDAR pixel
    bool cluster_8_neighbours = true;  // false: 4-neighbourhood
    int grid_step = 1;                 // matches sit on a grid of this step (neighbours are step px apart)
    // Whether to compute ConsistencyResult::after_sgm, the clustering after 2a (Table I's
    // "Disp+LiDAR"). 2b, its clustering and stage 3 are the same bit for bit without it: 2b only
    // removes matches, each by its own round trip, so the clustering after 2b removes every
    // region the first one would have (a region joins no neighbour it did not join before).
    bool after_sgm_field = true;

    // --- stage 3 ---
    int sparsify_block = 3;  // side of the non-overlapping blocks; 1 disables sparsification
    // Consistency of a match = mean round-trip error (stage 2b's normalised error) over the
    // sparsify_support x sparsify_support pixels around it, where a pixel without a surviving
    // match counts as sparsify_missing_error: a match inside a consistent region beats one at a
    // region's ragged edge. 1 = the match's own error only.
    int sparsify_support = 3;
    float sparsify_missing_error = 3.0f;  // = the worst normalised error a surviving match can have
};

}  // namespace lidarflow::consistency
