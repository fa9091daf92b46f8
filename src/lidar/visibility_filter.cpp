// SPDX-License-Identifier: MIT
#include "lidar/visibility_filter.hpp"

#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/limits.hpp"

namespace lidarflow::lidar {

void VisibilityFilterOptions::validate() const {
    const auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
    require(in(half_width, 0, 64) && in(half_height, 0, 64), ErrorCode::InvalidArgument,
            "LiDAR visibility filter: half_width and half_height must be in [0, 64]");
    require(in(ratio, 0, 10), ErrorCode::InvalidArgument, "LiDAR visibility filter: ratio must be in [0, 10]");
    require(in(margin, 0, kMaxLidarDisparity), ErrorCode::InvalidArgument,
            "LiDAR visibility filter: margin must be in [0, " + std::to_string(kMaxLidarDisparity) + "]");
}

SparseLidar remove_hidden_points(const SparseLidar &in, const VisibilityFilterOptions &o) {
    o.validate();
    if (!o.enabled || in.points.empty()) return in;
    in.validate(in.width, in.height, "LiDAR visibility filter: points");
    // The nearest point of every window at once: a max filter (dilation) of the sparse
    // disparity map, whose empty pixels (kInvalidDisparity < 0) never win.
    const DisparityMap map = in.to_map();
    DisparityMap nearest;
    cv::dilate(map, nearest,
               cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * o.half_width + 1, 2 * o.half_height + 1)),
               cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(kInvalidDisparity));
    SparseLidar out{in.width, in.height, {}};
    out.points.reserve(in.points.size());
    for (const LidarPoint &p : in.points)
        if (!(nearest(p.y, p.x) > p.disparity * (1.0f + o.ratio) + o.margin)) out.points.push_back(p);
    return out;
}

}  // namespace lidarflow::lidar
