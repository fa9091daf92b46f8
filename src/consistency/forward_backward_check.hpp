// SPDX-License-Identifier: MIT
#pragma once
// Stage 2b: forward-backward scene-flow check. The backward field B is matched with I_l^1 as
// reference (t1 -> t0): at a pixel q of I_l^1, (u_b, v_b) points back into I_l^0, d0_b is the
// disparity at t1 (of I_l^1 at q) and d1_b the disparity at t0 of that point. A forward match
// p -> q = p + (u, v) is consistent when B at q leads back to p with the same geometry:
//   |(u, v) + (u_b, v_b)(q)| <= fb_max_flow, |d0 - d1_b(q)| <= fb_max_d0, |d1 - d0_b(q)| <= fb_max_d1.
// With opt.fb_search_radius r > 0, B is also read at q' = q + (dx, dy), |dx|, |dy| <= r, and the
// best round trip counts, with the flow term |(u + dx, v + dy) + (u_b, v_b)(q')|. Why: a
// grid-based matcher (CPM style) copies each seed's match to its whole cell, so B holds the
// match of the nearest backward seed, which may sit up to a cell radius away from q.
#include <opencv2/core.hpp>

#include "consistency/lidar_reference.hpp"
#include "consistency/options.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency {

struct ForwardBackwardResult {
    SceneFlowField field;  // the consistent matches (zeros where invalid)
    // Round-trip error of every checked match, normalised by the thresholds:
    //   e_flow / fb_max_flow + e_d0 / fb_max_d0 + e_d1 / fb_max_d1   (e_d0 = 0 at LiDAR pixels)
    // so 0 is a perfect round trip and a surviving non-LiDAR match has at most 3. +inf where the
    // round trip could not be made (no match, q outside I_l^1, B invalid at q). Stage 3 ranks by it.
    cv::Mat1f error;
    // 1 where a LiDAR pixel's (u, v, d1) failed the check (or could not be checked). By default
    // such a match is removed from `field`; with opt.keep_unreliable_lidar it stays valid,
    // carrying its exact d0, but its motion must not be trusted (the clustering does not use it
    // as a reference).
    cv::Mat1b lidar_motion_unreliable;
};

// Runs the check on every valid match of `forward` (support-window pixels included; LiDAR pixels
// are checked on (u, v, d1) only and kept as opt.keep_unreliable_lidar says). A forward match whose q falls outside I_l^1
// or onto an invalid B pixel cannot be verified and is removed. Returns new maps; inputs are only
// read. Throws SizeMismatch when sizes differ, InvalidArgument on non-finite values at valid
// pixels or bad options.
ForwardBackwardResult forward_backward_check(const SceneFlowField &forward, const SceneFlowField &backward,
                                             const LidarReference &lidar, const ConsistencyOptions &opt);

}  // namespace lidarflow::consistency
