// SPDX-License-Identifier: MIT
#pragma once
// Forward and backward scene-flow fields made from KITTI-style ground truth, in the layout the
// matcher hands to stages 2-3. For tests and benchmarks of the consistency check (a perfect
// matcher), and as the clean base that a test corrupts the way image matching would.
#include "core/maps.hpp"

namespace lidarflow::consistency {

struct GroundTruthFields {
    SceneFlowField forward;   // in I_l^0: valid where d0, d1 and flow are all valid
    SceneFlowField backward;  // in I_l^1: the forward matches splatted to round(p + flow)
};

// d0, d1 (t1 disparity warped into I_l^0, as KITTI's disp_occ_1) and flow of one frame.
// Backward at q = round(p + (u, v)) is (-u, -v, d1, d0); where several p land on one q the nearest
// (largest d1) wins, as a camera at t1 sees the front surface. Confidence is 1 on valid pixels.
// The result owns its maps. Throws InvalidArgument on empty maps or non-finite valid values,
// SizeMismatch when the maps differ in size.
GroundTruthFields fields_from_ground_truth(const DisparityMap &d0, const DisparityMap &d1, const FlowField &flow);

}  // namespace lidarflow::consistency
