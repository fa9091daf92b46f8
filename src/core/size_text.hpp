// SPDX-License-Identifier: MIT
#pragma once
// An image size as messages print it: "WIDTHxHEIGHT".
#include <string>

#include <opencv2/core/types.hpp>

namespace lidarflow {

inline std::string size_text(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

}  // namespace lidarflow
