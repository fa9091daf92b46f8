// SPDX-License-Identifier: MIT
#pragma once
// One conversion of the estimator's 8-bit images (gray, BGR or BGRA) to gray, for every stage
// that needs intensities.
#include <opencv2/core.hpp>

namespace lidarflow {

// 8-bit gray of an 8-bit gray, BGR or BGRA image (a gray input is shared, not copied). Throws
// Error(InvalidArgument) for an empty image, another depth or another channel count.
cv::Mat1b gray8(const cv::Mat &image);

}  // namespace lidarflow
