// SPDX-License-Identifier: MIT
#pragma once
// Stages 2-3 of LiDAR-Flow in one call, plus the single stages (include this one header).
//
//   ConsistencyOptions opt;                       // documented defaults, see options.hpp
//   ConsistencyResult r = run_consistency(forward, backward, left0, right0, lidar0, opt);
//   r.after_fb  -> stage 2 output (Table I "disp+LiDAR & backward+LiDAR")
//   r.sparse    -> stage 3 output, the interpolation's input ("Spars+LiDAR")
//
// Image-only mode (the SFF++ comparison rows): pass a SparseLidar without points.
// The steps are 2a sgm_check -> remove_small_clusters (with opt.after_sgm_field) -> 2b
// forward_backward_check -> remove_small_clusters -> 3 sparsify. Every valid LiDAR pixel of
// the forward field survives all of them, carrying the LiDAR disparity as its d0, unless its
// (u, v, d1) fail stage 2b (see ConsistencyOptions::keep_unreliable_lidar; such pixels are
// listed in lidar_motion_unreliable either way).
#include <opencv2/core.hpp>

#include "consistency/clustering.hpp"
#include "consistency/forward_backward_check.hpp"
#include "consistency/lidar_reference.hpp"
#include "consistency/options.hpp"
#include "consistency/sgm_check.hpp"
#include "consistency/sparsify.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency {

// Valid matches after each step (the input count is after the LiDAR d0 is put in);
// after_sgm_clusters 0 and after_fb_check counted on 2a's output without after_sgm_field.
struct ConsistencyCounts {
    long long input = 0, after_sgm_check = 0, after_sgm_clusters = 0, after_fb_check = 0,
              after_fb_clusters = 0, sparse = 0;
    int lidar_pixels = 0;             // distinct D_l^0 pixels
    int lidar_motion_unreliable = 0;  // of those, with (u, v, d1) failing stage 2b
};

// Wall-clock seconds of each step (sgm = 0 when the SGM disparity was passed in).
struct ConsistencyTimings {
    double sgm = 0, sgm_check = 0, sgm_clusters = 0, fb_check = 0, fb_clusters = 0, sparsify = 0, total = 0;
};

struct ConsistencyResult {
    DisparityMap sgm;          // reference disparity of stage 2a
    SceneFlowField after_sgm;  // 2a + clustering   (Table I "Disp+LiDAR"; empty without after_sgm_field)
    SceneFlowField after_fb;   // 2b + clustering   (Table I "disp+LiDAR & backward+LiDAR")
    SceneFlowField sparse;     // stage 3           (Table I "Spars+LiDAR")
    cv::Mat1f fb_error;        // ForwardBackwardResult::error
    cv::Mat1b lidar_pixels;    // LidarReference::is_lidar
    cv::Mat1b lidar_motion_unreliable;  // ForwardBackwardResult::lidar_motion_unreliable
    ConsistencyCounts counts;
    ConsistencyTimings seconds;
};

// forward: matches in I_l^0 (t0 -> t1); backward: matches in I_l^1 (t1 -> t0), same size;
// left0/right0: the rectified t0 pair for SGM; lidar0: D_l^0 aligned to I_l^0 (no points =
// image-only). The result owns all its maps; inputs are only read. Throws SizeMismatch for
// inputs of different sizes, InvalidArgument for empty inputs, non-finite values at valid
// pixels, bad LiDAR points or bad options.
ConsistencyResult run_consistency(const SceneFlowField &forward, const SceneFlowField &backward, const cv::Mat &left0,
                                  const cv::Mat &right0, const SparseLidar &lidar0,
                                  const ConsistencyOptions &opt = {});

// The same with a precomputed reference disparity for stage 2a (e.g. shared by the LiDAR and
// image-only runs of an ablation); sgm must be the size of the fields.
ConsistencyResult run_consistency(const SceneFlowField &forward, const SceneFlowField &backward,
                                  const DisparityMap &sgm, const SparseLidar &lidar0,
                                  const ConsistencyOptions &opt = {});

}  // namespace lidarflow::consistency
