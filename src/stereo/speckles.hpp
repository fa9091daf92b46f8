// SPDX-License-Identifier: MIT
#pragma once
// OpenCV's speckle filter on the stage's threads. cv::filterSpeckles flood-fills one region at a
// time on one thread (~2 ms a 683x206 disparity map, serial in every stereo run); the regions it
// finds are the connected components of a relation between 4-neighbours, which a union-find
// over bands of rows finds as well, in parallel, with the same result.
#include <cstdint>

#include <opencv2/core.hpp>

namespace lidarflow::stereo {

// What cv::filterSpeckles(disp, new_value, max_size, max_diff) does to a CV_16S map: every
// region of 4-connected pixels other than new_value, neighbours differing by at most max_diff,
// that has at most max_size pixels becomes new_value. On `threads` threads (>= 1; the same
// result on any count). Nothing happens when max_size <= 0. Throws Error(InvalidArgument) for
// a map of 2^31 pixels or more, or max_diff < 0.
void filter_speckles(cv::Mat1s &disp, int16_t new_value, int max_size, int max_diff, int threads);

}  // namespace lidarflow::stereo
