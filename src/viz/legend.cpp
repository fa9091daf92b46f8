// SPDX-License-Identifier: MIT
#include "viz/legend.hpp"

#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "viz/disparity_color.hpp"

namespace lidarflow::viz {
namespace {

const cv::Scalar kBackground(40, 40, 40), kText(235, 235, 235);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.45;

void check_picture(const cv::Mat &picture) {
    require(!picture.empty() && picture.type() == CV_8UC3, ErrorCode::InvalidArgument,
            "legend: the picture must be a non-empty 8-bit BGR image");
}

// picture on top of a strip of `height` rows (and at least `min_width` columns).
cv::Mat stacked(const cv::Mat &picture, int height, int min_width, cv::Mat *strip) {
    const int w = std::max(picture.cols, min_width);
    cv::Mat out(picture.rows + height, w, CV_8UC3, kBackground);
    picture.copyTo(out(cv::Rect(0, 0, picture.cols, picture.rows)));
    *strip = out(cv::Rect(0, picture.rows, w, height));
    return out;
}

std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", std::fabs(v) < 1e-12 ? 0.0 : v);
    return buf;
}

int text_width(const std::string &s) {
    int base = 0;
    return cv::getTextSize(s, kFont, kFontScale, 1, &base).width;
}

}  // namespace

cv::Mat with_color_bar(const cv::Mat &picture, const std::function<cv::Vec3b(double)> &color, double lo, double hi,
                       const std::string &label) {
    check_picture(picture);
    require(std::isfinite(lo) && std::isfinite(hi) && hi > lo, ErrorCode::InvalidArgument,
            "legend: the colour bar needs a finite range with hi > lo");
    const int label_w = text_width(label) + 16, min_bar = 120;
    cv::Mat strip;
    cv::Mat out = stacked(picture, 44, label_w + min_bar + 24, &strip);
    cv::putText(strip, label, {8, 20}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    const int x0 = label_w, x1 = strip.cols - 20;  // room for the last tick's number
    for (int x = x0; x <= x1; ++x) {
        const cv::Vec3b c = color(lo + (hi - lo) * (x - x0) / static_cast<double>(x1 - x0));
        cv::line(strip, {x, 6}, {x, 22}, cv::Scalar(c[0], c[1], c[2]));
    }
    cv::rectangle(strip, {x0 - 1, 5}, {x1 + 1, 23}, kText);
    for (int k = 0; k <= 4; ++k) {
        const int x = x0 + (x1 - x0) * k / 4;
        cv::line(strip, {x, 23}, {x, 27}, kText);
        const std::string s = number(lo + (hi - lo) * k / 4.0);
        cv::putText(strip, s, {x - text_width(s) / 2, 40}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    }
    return out;
}

cv::Mat with_disparity_legend(const cv::Mat &picture, double max_disp) {
    require(std::isfinite(max_disp) && max_disp > 0, ErrorCode::InvalidArgument, "legend: max_disp must be > 0");
    return with_color_bar(
        picture, [max_disp](double d) { return disparity_color(d, max_disp); }, 0.0, max_disp,
        "disparity [px] (near = bright)");
}

cv::Mat with_flow_legend(const cv::Mat &picture, double max_flow, FlowColorStyle style) {
    check_picture(picture);
    require(std::isfinite(max_flow) && max_flow > 0, ErrorCode::InvalidArgument, "legend: max_flow must be > 0");
    const int r = 30, size = 2 * r + 1;
    const std::string line1 = "flow: hue = direction (+u right, +v down)";
    const std::string line2 = "rim of the wheel = " + number(max_flow) + " px" +
                              (style == FlowColorStyle::Kitti ? " (KITTI colours)" : " (Middlebury colours)");
    cv::Mat strip;
    cv::Mat out = stacked(picture, size + 8, size + 24 + std::max(text_width(line1), text_width(line2)), &strip);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const double u = (x - r) * max_flow / r, v = (y - r) * max_flow / r;
            if (u * u + v * v > max_flow * max_flow) continue;
            strip.at<cv::Vec3b>(y + 4, x + 8) = flow_color(u, v, max_flow, style);
        }
    cv::circle(strip, {8 + r, 4 + r}, r + 1, kText, 1, cv::LINE_AA);
    cv::putText(strip, line1, {size + 20, 4 + r - 6}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    cv::putText(strip, line2, {size + 20, 4 + r + 14}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    return out;
}

}  // namespace lidarflow::viz
