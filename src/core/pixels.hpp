// SPDX-License-Identifier: MIT
#pragma once
// Exact image equality, for caches that may reuse work only on pixel-identical inputs.
#include <cstring>

#include <opencv2/core.hpp>

namespace lidarflow {

// Same size, same type and every byte of every row equal (any strides). Never throws.
inline bool pixel_identical(const cv::Mat &a, const cv::Mat &b) {
    if (a.size() != b.size() || a.type() != b.type()) return false;
    const size_t row = a.cols * a.elemSize();
    for (int y = 0; y < a.rows; ++y)
        if (std::memcmp(a.ptr(y), b.ptr(y), row) != 0) return false;
    return true;
}

}  // namespace lidarflow
