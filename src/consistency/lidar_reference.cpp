// SPDX-License-Identifier: MIT
#include "consistency/lidar_reference.hpp"

#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency {

LidarReference LidarReference::build(const SparseLidar &lidar, int width, int height, int window) {
    require(width > 0 && height > 0, ErrorCode::InvalidArgument, "consistency: empty image size");
    require(window >= 1 && window % 2 == 1, ErrorCode::InvalidArgument,
            "consistency: support window must be odd and >= 1, got " + std::to_string(window));
    LidarReference ref;
    ref.is_lidar = cv::Mat1b::zeros(height, width);
    ref.disparity = filled(height, width, kInvalidDisparity);
    if (lidar.points.empty()) {
        ref.in_window = cv::Mat1b::zeros(height, width);
        return ref;
    }
    require(lidar.width == width && lidar.height == height, ErrorCode::SizeMismatch,
            "consistency: LiDAR aligned to " + std::to_string(lidar.width) + "x" +
                std::to_string(lidar.height) + " but the fields are " + std::to_string(width) + "x" +
                std::to_string(height));
    for (const LidarPoint &p : lidar.points) {
        require(p.x >= 0 && p.y >= 0 && p.x < width && p.y < height, ErrorCode::InvalidArgument,
                "consistency: LiDAR point outside the image");
        require(std::isfinite(p.disparity) && p.disparity >= 0.0f, ErrorCode::InvalidArgument,
                "consistency: LiDAR point with a non-finite or negative disparity");
        if (!ref.is_lidar(p.y, p.x)) ++ref.count;
        ref.is_lidar(p.y, p.x) = 1;
        ref.disparity(p.y, p.x) = p.disparity;
    }
    // A square window centred on every point = dilation of the point mask by a square.
    cv::dilate(ref.is_lidar, ref.in_window, cv::getStructuringElement(cv::MORPH_RECT, {window, window}),
               cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    return ref;
}

}  // namespace lidarflow::consistency
