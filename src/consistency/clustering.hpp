// SPDX-License-Identifier: MIT
#pragma once
// Clustering after each filtering stage: the remaining matches are segmented into regions of
// similar scene flow (connected components, neighbours joined when all four components are
// close); regions smaller than opt.cluster_min_size are removed as isolated mismatches. LiDAR
// pixels are the reference values: a region holding a trusted LiDAR pixel is kept whatever its
// size (opt.keep_lidar_clusters), and LiDAR pixels themselves are never removed.
#include <opencv2/core.hpp>

#include "consistency/lidar_reference.hpp"
#include "consistency/options.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency {

struct ClusterResult {
    SceneFlowField field;  // the surviving matches (zeros where invalid)
    int clusters = 0;          // regions found
    int removed_clusters = 0;  // regions dropped as too small
    long long removed_matches = 0;
};

// Segments the valid matches of `field`. Neighbours are opt.grid_step pixels apart (4- or
// 8-connected by opt.cluster_8_neighbours). lidar_motion_unreliable (may be empty) marks LiDAR
// pixels whose (u, v, d1) failed stage 2b: they are kept but do not make their region a LiDAR
// region. Returns a new field; inputs are only read. Throws SizeMismatch when sizes differ,
// InvalidArgument on non-finite values at valid pixels or bad options.
ClusterResult remove_small_clusters(const SceneFlowField &field, const LidarReference &lidar,
                                    const cv::Mat1b &lidar_motion_unreliable, const ConsistencyOptions &opt);

}  // namespace lidarflow::consistency
