// SPDX-License-Identifier: MIT
#pragma once
// The final result's confidence: stage 4's support of the pixel's models (the superpixel's
// inlier share), raised where stage 1 measured the same motion nearby. An interpolated value
// that no nearby measurement confirms is wrong more often than one that a match agrees with.
#include "core/maps.hpp"

namespace lidarflow::pipeline {

// Rewrites dense.confidence (where dense.valid) as (share + weight * s) / (1 + weight), with s
// the share of pixels in the (2 radius + 1)^2 box around the pixel where `measured` (stage 1's
// forward field: u, v, d0, valid read) is valid and agrees with `dense` within `tolerance` px
// in u, v and d0. Values stay in [0, 1] when the shares are. Sizes must match (else unchanged).
// On `threads` threads (the same result on any count).
void add_measured_support(SceneFlowField &dense, const SceneFlowField &measured, int radius, float tolerance,
                          float weight, int threads = 1);

}  // namespace lidarflow::pipeline
