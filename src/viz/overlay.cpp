// SPDX-License-Identifier: MIT
#include "viz/overlay.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "viz/disparity_color.hpp"

namespace lidarflow::viz {
namespace {

cv::Mat to_bgr(const cv::Mat &image, const char *who) {
    require(!image.empty() && image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3),
            ErrorCode::InvalidArgument, std::string(who) + ": expected a non-empty 8-bit grey or BGR image");
    cv::Mat out;
    if (image.channels() == 1)
        cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
    else
        out = image.clone();
    return out;
}

}  // namespace

cv::Mat blend_over(const cv::Mat &image, const cv::Mat &colors, const cv::Mat1b &mask, double alpha) {
    cv::Mat out = to_bgr(image, "blend_over");
    require(!colors.empty() && colors.type() == CV_8UC3, ErrorCode::InvalidArgument,
            "blend_over: the colours must be an 8-bit BGR image");
    require(alpha >= 0 && alpha <= 1, ErrorCode::InvalidArgument, "blend_over: alpha must be in [0, 1]");
    require(colors.size() == out.size() && mask.size() == out.size(), ErrorCode::SizeMismatch,
            "blend_over: image, colours and mask differ in size");
    for (int y = 0; y < out.rows; ++y) {
        cv::Vec3b *o = out.ptr<cv::Vec3b>(y);
        const cv::Vec3b *c = colors.ptr<cv::Vec3b>(y);
        for (int x = 0; x < out.cols; ++x)
            for (int k = 0; k < 3; ++k) {
                const double v = mask(y, x) ? alpha * c[x][k] + (1 - alpha) * o[x][k] : 0.5 * o[x][k];
                o[x][k] = static_cast<uchar>(std::lround(v));
            }
    }
    return out;
}

cv::Mat draw_lidar(const cv::Mat &image, const SparseLidar &lidar, float max_disp, int radius) {
    cv::Mat out = to_bgr(image, "draw_lidar");
    require(radius >= 1, ErrorCode::InvalidArgument, "draw_lidar: radius must be >= 1");
    require(lidar.width == image.cols && lidar.height == image.rows, ErrorCode::SizeMismatch,
            "draw_lidar: LiDAR frame size differs from the image");
    require(std::isfinite(max_disp), ErrorCode::InvalidArgument, "draw_lidar: max_disp must be finite");
    if (lidar.points.empty()) return out;
    // One row of point disparities coloured at once, so the colours match disparity_to_color.
    DisparityMap values(1, static_cast<int>(lidar.points.size()));
    float max_d = max_disp;
    for (size_t i = 0; i < lidar.points.size(); ++i) {
        values(0, static_cast<int>(i)) = lidar.points[i].disparity;
        if (max_disp <= 0 && std::isfinite(lidar.points[i].disparity)) max_d = std::max(max_d, lidar.points[i].disparity);
    }
    const cv::Mat colours = disparity_to_color(values, max_d > 0 ? max_d : 1.0f);
    for (size_t i = 0; i < lidar.points.size(); ++i) {
        const cv::Point p(lidar.points[i].x, lidar.points[i].y);
        const cv::Vec3b c = colours.at<cv::Vec3b>(0, static_cast<int>(i));
        cv::circle(out, p, radius + 1, cv::Scalar(0, 0, 0), cv::FILLED, cv::LINE_AA);
        cv::circle(out, p, radius, cv::Scalar(c[0], c[1], c[2]), cv::FILLED, cv::LINE_AA);
    }
    return out;
}

cv::Mat overlay_mask(const cv::Mat &image, const cv::Mat1b &mask, const cv::Scalar &bgr, double alpha) {
    cv::Mat out = to_bgr(image, "overlay_mask");
    require(mask.size() == image.size(), ErrorCode::SizeMismatch, "overlay_mask: mask size differs from the image");
    require(std::isfinite(alpha) && alpha >= 0 && alpha <= 1, ErrorCode::InvalidArgument,
            "overlay_mask: alpha must be in [0, 1]");
    for (int y = 0; y < out.rows; ++y) {
        cv::Vec3b *row = out.ptr<cv::Vec3b>(y);
        for (int x = 0; x < out.cols; ++x) {
            if (!mask(y, x)) continue;
            for (int c = 0; c < 3; ++c)
                row[x][c] = cv::saturate_cast<uint8_t>((1 - alpha) * row[x][c] + alpha * bgr[c]);
        }
    }
    return out;
}

cv::Mat tile(const std::vector<cv::Mat> &images, int cols) {
    require(!images.empty() && cols >= 1, ErrorCode::InvalidArgument, "tile: need images and cols >= 1");
    int cw = 0, ch = 0;
    for (const cv::Mat &m : images) {
        require(!m.empty() && m.type() == CV_8UC3, ErrorCode::InvalidArgument, "tile: every image must be CV_8UC3");
        cw = std::max(cw, m.cols);
        ch = std::max(ch, m.rows);
    }
    const int n = static_cast<int>(images.size()), ncols = std::min(cols, n), nrows = (n + cols - 1) / cols;
    const int gutter = 4;
    cv::Mat out(nrows * ch + (nrows - 1) * gutter, ncols * cw + (ncols - 1) * gutter, CV_8UC3, cv::Scalar(0, 0, 0));
    for (int i = 0; i < n; ++i) {
        const int r = i / cols, c = i % cols;
        images[i].copyTo(out(cv::Rect(c * (cw + gutter), r * (ch + gutter), images[i].cols, images[i].rows)));
    }
    return out;
}

}  // namespace lidarflow::viz
