// SPDX-License-Identifier: MIT
#include "viz/legend.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "viz/disparity_color.hpp"
#include "viz/error_map.hpp"

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

// A tick value written with as many decimals as the step needs (0.2, not 0.20000000001).
std::string tick_label(double v, double step) {
    const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, std::fabs(v) < step * 1e-6 ? 0.0 : v);
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
    const int label_w = text_width(label) + 16, min_bar = 200;
    cv::Mat strip;
    cv::Mat out = stacked(picture, 44, label_w + min_bar + 24, &strip);
    cv::putText(strip, label, {8, 20}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    const int x0 = label_w, x1 = strip.cols - 20;  // room for the last tick's number
    for (int x = x0; x <= x1; ++x) {
        const cv::Vec3b c = color(lo + (hi - lo) * (x - x0) / static_cast<double>(x1 - x0));
        cv::line(strip, {x, 6}, {x, 22}, cv::Scalar(c[0], c[1], c[2]));
    }
    cv::rectangle(strip, {x0 - 1, 5}, {x1 + 1, 23}, kText);
    const double step = round_tick_step(lo, hi);
    for (double t : round_ticks(lo, hi)) {
        const int x = x0 + static_cast<int>(std::lround((x1 - x0) * (t - lo) / (hi - lo)));
        cv::line(strip, {x, 23}, {x, 27}, kText);
        const std::string s = tick_label(t, step);
        cv::putText(strip, s, {x - text_width(s) / 2, 40}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    }
    return out;
}

double round_tick_step(double lo, double hi) {
    require(std::isfinite(lo) && std::isfinite(hi) && hi > lo, ErrorCode::InvalidArgument,
            "legend: ticks need a finite range with hi > lo");
    // The smallest 1, 2 or 5 x 10^k that cuts the range into at most 5 steps.
    const double raw = (hi - lo) / 5.0;
    const double decade = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (m * decade >= raw * (1 - 1e-9)) return m * decade;
    return 10.0 * decade;
}

std::vector<double> round_ticks(double lo, double hi) {
    const double step = round_tick_step(lo, hi);
    std::vector<double> ticks;
    for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + step * 1e-9; k += 1.0)
        ticks.push_back(std::fabs(k) < 1e-12 ? 0.0 : k * step);
    return ticks;
}

cv::Mat with_error_legend(const cv::Mat &picture) {
    check_picture(picture);
    // The ten bands of log_error_color, in units of the KITTI outlier threshold; the bar shows
    // them side by side with the band limits, the threshold (1) marked.
    static const char *const kLimits[9] = {"1/16", "1/8", "1/4", "1/2", "1", "2", "4", "8", "16"};
    static const double kLower[10] = {0, 1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 2, 1, 2, 4, 8, 16};
    const std::string title = "error / max(3 px, 5 % of true value), log scale; black: no ground truth";
    const std::string inl = "inliers", outl = "KITTI outliers (> 3 px and > 5 %)";
    const int bar_min = 10 * 40;
    cv::Mat strip;
    cv::Mat out = stacked(picture, 80, std::max(text_width(title), bar_min) + 16, &strip);
    cv::putText(strip, title, {8, 16}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    const int x0 = 8, x1 = std::min(strip.cols - 8, x0 + std::max(bar_min, text_width(title)));
    const int y0 = 24, y1 = 40;
    auto edge = [&](int k) { return x0 + (x1 - x0) * k / 10; };
    for (int k = 0; k < 10; ++k) {
        const cv::Vec3b c = log_error_color(kLower[k]);
        cv::rectangle(strip, {edge(k), y0}, {edge(k + 1) - 1, y1}, cv::Scalar(c[0], c[1], c[2]), cv::FILLED);
    }
    cv::rectangle(strip, {x0 - 1, y0 - 1}, {x1, y1 + 1}, kText);
    for (int k = 1; k < 10; ++k) {
        const int x = edge(k);
        const std::string s = kLimits[k - 1];
        cv::line(strip, {x, y1 + 1}, {x, y1 + 4}, kText);
        cv::putText(strip, s, {x - text_width(s) / 2, y1 + 17}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    }
    // The threshold: a bold white line through the bar at 1 down between the two halves' names.
    const int xt = edge(5);
    cv::rectangle(strip, {xt - 1, y0 - 3}, {xt + 1, y1 + 3}, cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(strip, {xt - 1, y1 + 22}, {xt + 1, y1 + 38}, cv::Scalar(255, 255, 255), cv::FILLED);
    cv::putText(strip, inl, {std::max(x0, (x0 + xt) / 2 - text_width(inl) / 2), y1 + 34}, kFont, kFontScale, kText, 1,
                cv::LINE_AA);
    cv::putText(strip, outl, {std::max(xt + 6, (xt + x1) / 2 - text_width(outl) / 2), y1 + 34}, kFont, kFontScale,
                kText, 1, cv::LINE_AA);
    return out;
}

cv::Mat with_disparity_legend(const cv::Mat &picture, double max_disp, const std::string &label) {
    require(std::isfinite(max_disp) && max_disp > 0, ErrorCode::InvalidArgument, "legend: max_disp must be > 0");
    return with_color_bar(
        picture, [max_disp](double d) { return disparity_color(d, max_disp); }, 0.0, max_disp, label);
}

cv::Mat with_marks_legend(const cv::Mat &picture, const std::vector<LegendMark> &marks) {
    check_picture(picture);
    require(!marks.empty(), ErrorCode::InvalidArgument, "legend: no marks to explain");
    constexpr int kRow = 20, kGlyph = 24;
    int label_w = 0;
    for (const LegendMark &m : marks) label_w = std::max(label_w, text_width(m.label));
    cv::Mat strip;
    cv::Mat out = stacked(picture, kRow * static_cast<int>(marks.size()) + 6, 8 + kGlyph + 8 + label_w + 8, &strip);
    for (size_t i = 0; i < marks.size(); ++i) {
        const LegendMark &m = marks[i];
        const int y = 4 + kRow * static_cast<int>(i), mid = y + kRow / 2;
        const cv::Point a(8, mid), b(8 + kGlyph, mid);
        switch (m.glyph) {
        case LegendMark::Glyph::Swatch:
            cv::rectangle(strip, {8, y + 3}, {8 + kGlyph, y + kRow - 3}, m.color, cv::FILLED);
            cv::rectangle(strip, {8, y + 3}, {8 + kGlyph, y + kRow - 3}, kText);  // black and dark swatches stay visible
            break;
        case LegendMark::Glyph::Line: cv::line(strip, a, b, m.color, 1, cv::LINE_AA); break;
        case LegendMark::Glyph::Arrow: cv::arrowedLine(strip, a, b, m.color, 1, cv::LINE_AA, 0, 0.3); break;
        case LegendMark::Glyph::Triangle: {
            const cv::Point tri[3] = {{8 + kGlyph / 2, y + 3}, {8 + kGlyph / 2 - 7, y + kRow - 3},
                                      {8 + kGlyph / 2 + 7, y + kRow - 3}};
            cv::fillConvexPoly(strip, tri, 3, m.color, cv::LINE_AA);
            break;
        }
        }
        cv::putText(strip, m.label, {8 + kGlyph + 8, mid + 5}, kFont, kFontScale, kText, 1, cv::LINE_AA);
    }
    return out;
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
