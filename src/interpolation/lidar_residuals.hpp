// SPDX-License-Identifier: MIT
#pragma once
// LiDAR residuals spread over the pixels of their model: a superpixel's plane fits its
// neighbourhood, not each point, so the measured disparity minus the plane at a LiDAR point
// is a local correction for the pixels near it that use the same plane (a dense scan then
// carries its detail into larger superpixels).
#include <vector>

#include <opencv2/core.hpp>

namespace lidarflow::interpolation {

// correction(q) = sum_i w_i r_i / (sum_i w_i + prior_weight) over the points i within
// `radius` of pixel q whose pixel uses q's model (model_of(point) == model_of(q)), with
// w_i = (1 - dist^2 / radius^2)^2: a point on the pixel itself weighs 1, the model
// prior_weight. 0 where no point reaches. `points` lie inside model_of, one residual each.
// radius in [0, 64] (0: all zero), prior_weight > 0, threads in [1, 1024]. Pure and thread-safe;
// the same result on every call and for any thread count.
cv::Mat1f lidar_residual_correction(const cv::Mat1i &model_of, const std::vector<cv::Point> &points,
                                    const std::vector<float> &residuals, float radius, float prior_weight,
                                    int threads = 1);

}  // namespace lidarflow::interpolation
