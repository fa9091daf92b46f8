// SPDX-License-Identifier: MIT
#pragma once
// Legends for the colour-coded pictures: a strip appended below a picture, with a colour bar and
// its scale (disparity, speed) or a colour wheel (flow), so a picture read on its own says what
// its colours mean.
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "viz/flow_color.hpp"

namespace lidarflow::viz {

// Copy of `picture` (CV_8UC3) with a strip below: `label`, then a bar coloured by color(t) for t
// from lo to hi, with ticks at round_ticks(lo, hi). Throws Error(InvalidArgument) for an empty or non-BGR
// picture, or a non-finite / empty range (hi <= lo).
cv::Mat with_color_bar(const cv::Mat &picture, const std::function<cv::Vec3b(double)> &color, double lo, double hi,
                       const std::string &label);

// Round tick values of a colour bar over [lo, hi]: the multiples in [lo, hi] of the smallest step
// 1, 2 or 5 x 10^k that cuts the range into at most 5 steps (0..88.8 -> 0, 20, 40, 60, 80).
// Throws Error(InvalidArgument) for a non-finite or empty range.
double round_tick_step(double lo, double hi);
std::vector<double> round_ticks(double lo, double hi);

// Copy of `picture` with the legend of a KITTI log-colour error map (viz/error_map.hpp) below:
// the ten bands with their limits in units of the outlier threshold, 1 (3 px and 5 %) marked.
cv::Mat with_error_legend(const cv::Mat &picture);

// with_color_bar with disparity_color over [0, max_disp] (max_disp > 0), under `label`.
cv::Mat with_disparity_legend(const cv::Mat &picture, double max_disp,
                              const std::string &label = "disparity [px] (near = bright)");

// One entry of a key to marks drawn on a picture: a glyph in its colour, then its label.
struct LegendMark {
    enum class Glyph { Swatch, Line, Arrow, Triangle };
    Glyph glyph;
    cv::Scalar color;  // BGR
    std::string label;
};

// Copy of `picture` with a strip below holding one row per mark. Throws Error(InvalidArgument)
// for an empty or non-BGR picture or no marks.
cv::Mat with_marks_legend(const cv::Mat &picture, const std::vector<LegendMark> &marks);

// Copy of `picture` with a strip holding the colour wheel of `style` at normalisation max_flow
// (> 0): the wheel's rim is |f| = max_flow, +u to the right, +v down, as in the picture.
cv::Mat with_flow_legend(const cv::Mat &picture, double max_flow, FlowColorStyle style);

}  // namespace lidarflow::viz
