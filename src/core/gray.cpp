// SPDX-License-Identifier: MIT
#include "core/gray.hpp"

#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace lidarflow {

cv::Mat1b gray8(const cv::Mat &image) {
    require(!image.empty(), ErrorCode::InvalidArgument, "gray8: empty image");
    require(image.depth() == CV_8U, ErrorCode::InvalidArgument, "gray8: image must be 8-bit");
    cv::Mat1b gray;
    switch (image.channels()) {
    case 1: return image;
    case 3: cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY); return gray;
    case 4: cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY); return gray;
    default:
        throw Error(ErrorCode::InvalidArgument,
                    "gray8: expected 1, 3 or 4 channels, got " + std::to_string(image.channels()));
    }
}

}  // namespace lidarflow
