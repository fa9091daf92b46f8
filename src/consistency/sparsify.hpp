// SPDX-License-Identifier: MIT
#pragma once
// Stage 3: sparsification before the interpolation (as in SceneFlowFields). In each
// non-overlapping opt.sparsify_block x opt.sparsify_block block (aligned at (0, 0); the last
// row / column of blocks may be cut by the image border) the non-LiDAR match with the highest
// consistency is kept. Consistency: the lowest mean of stage 2b's normalised round-trip `error`
// over the opt.sparsify_support window around the match (pixels without a surviving match count
// as opt.sparsify_missing_error), ties broken by the higher matcher confidence, then by the first
// pixel in raster order. Every valid LiDAR pixel is kept in addition.
#include <opencv2/core.hpp>

#include "consistency/lidar_reference.hpp"
#include "consistency/options.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency {

// Returns a new field (zeros where invalid); inputs are only read. error is the map of
// ForwardBackwardResult::error (NaN not allowed; +inf ranks last). Throws SizeMismatch when
// sizes differ, InvalidArgument on non-finite values at valid pixels, NaN in error, or bad options.
SceneFlowField sparsify(const SceneFlowField &field, const cv::Mat1f &error, const LidarReference &lidar,
                        const ConsistencyOptions &opt);

}  // namespace lidarflow::consistency
