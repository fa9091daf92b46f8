// SPDX-License-Identifier: MIT
#pragma once
// The estimator's reduction of full-size frames to its processing size: OpenCV's INTER_AREA
// (each output pixel the mean of the input area it covers) with the same weights and the same
// floating-point sums, so the same bytes, but faster on a fractional ratio such as 0.55, where
// OpenCV's version accumulates through memory one weight at a time (bench_downscale).
#include <opencv2/core.hpp>

namespace lidarflow {

// dst = cv::resize(src, size, INTER_AREA), bit for bit, on `threads` OpenMP threads. src: 8-bit,
// 1 to 4 channels, not smaller than `size` on either side (other inputs and integer ratios, which
// OpenCV averages in integers, go to cv::resize itself). dst is replaced (it may be src). Throws Error(InvalidArgument) for an empty src, a size below 1x1 or threads < 1.
// Thread-safe (no shared state).
void area_downscale(const cv::Mat &src, cv::Mat &dst, cv::Size size, int threads);

}  // namespace lidarflow
