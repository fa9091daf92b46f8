// SPDX-License-Identifier: MIT
#pragma once
// The steps of stages 2-3 on options checked once (CheckedOptions): run_consistency checks its
// options where they enter and walks a frame through these, so no step checks them again. The
// public step functions (sgm_check.hpp, clustering.hpp, forward_backward_check.hpp,
// sparsify.hpp) check the options they are given and call these. Internal to src/consistency.
#include <opencv2/core.hpp>

#include "consistency/clustering.hpp"
#include "consistency/forward_backward_check.hpp"
#include "consistency/lidar_reference.hpp"
#include "consistency/sgm_check.hpp"
#include "consistency/sparsify.hpp"
#include "consistency/validate.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency::detail {

// compute_sgm_disparity with opt.get().sgm.
DisparityMap compute_sgm_disparity(const cv::Mat &left, const cv::Mat &right, const CheckedOptions &opt);

SceneFlowField sgm_check(const SceneFlowField &forward, const DisparityMap &sgm, const LidarReference &lidar,
                         const CheckedOptions &opt);

ClusterResult remove_small_clusters(const SceneFlowField &field, const LidarReference &lidar,
                                    const cv::Mat1b &lidar_motion_unreliable, const CheckedOptions &opt);

ForwardBackwardResult forward_backward_check(const SceneFlowField &forward, const SceneFlowField &backward,
                                             const LidarReference &lidar, const CheckedOptions &opt);

SceneFlowField sparsify(const SceneFlowField &field, const cv::Mat1f &error, const LidarReference &lidar,
                        const CheckedOptions &opt);

}  // namespace lidarflow::consistency::detail
