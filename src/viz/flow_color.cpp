// SPDX-License-Identifier: MIT
#include "viz/flow_color.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "core/error.hpp"

namespace lidarflow::viz {
namespace {

constexpr double kPi = 3.14159265358979323846;

bool usable(const FlowField &f, int y, int x) {
    return f.valid(y, x) && std::isfinite(f.u(y, x)) && std::isfinite(f.v(y, x));
}

// HSV -> RGB with h, s, v in [0, 1].
std::array<double, 3> hsv_to_rgb(double h, double s, double v) {
    const double c = v * s, h6 = 6.0 * (h - std::floor(h));
    const double x = c * (1.0 - std::fabs(std::fmod(h6, 2.0) - 1.0)), m = v - c;
    double r = 0, g = 0, b = 0;
    switch (std::min(static_cast<int>(h6), 5)) {
        case 0: r = c, g = x; break;
        case 1: r = x, g = c; break;
        case 2: g = c, b = x; break;
        case 3: g = x, b = c; break;
        case 4: r = x, b = c; break;
        default: r = c, b = x; break;
    }
    return {r + m, g + m, b + m};
}

cv::Vec3b bgr(double r, double g, double b) {
    auto q = [](double v) { return static_cast<uint8_t>(std::lround(std::min(std::max(v, 0.0), 1.0) * 255.0)); };
    return {q(b), q(g), q(r)};
}

cv::Vec3b kitti_color(double u, double v, double max_flow) {
    const double n = 8.0;  // the devkit's saturation multiplier
    const double mag = std::sqrt(u * u + v * v);
    const double hue = std::atan2(v, u) / (2.0 * kPi);
    const double s = std::min(std::max(mag * n / max_flow, 0.0), 1.0);
    const double val = std::min(std::max(n - mag * n / max_flow, 0.0), 1.0);
    const auto rgb = hsv_to_rgb(hue, s, val);
    return bgr(rgb[0], rgb[1], rgb[2]);
}

// The Middlebury wheel: red -> yellow -> green -> cyan -> blue -> magenta segments whose
// lengths follow perceptual colour differences.
const std::vector<std::array<double, 3>> &middlebury_wheel() {
    static const std::vector<std::array<double, 3>> wheel = [] {
        const int segments[6] = {15, 6, 4, 11, 13, 6};  // RY, YG, GC, CB, BM, MR
        std::vector<std::array<double, 3>> w;
        for (int seg = 0; seg < 6; ++seg)
            for (int i = 0; i < segments[seg]; ++i) {
                const double up = std::floor(255.0 * i / segments[seg]) / 255.0, down = 1.0 - up;
                switch (seg) {
                    case 0: w.push_back({1, up, 0}); break;
                    case 1: w.push_back({down, 1, 0}); break;
                    case 2: w.push_back({0, 1, up}); break;
                    case 3: w.push_back({0, down, 1}); break;
                    case 4: w.push_back({up, 0, 1}); break;
                    default: w.push_back({1, 0, down}); break;
                }
            }
        return w;
    }();
    return wheel;
}

cv::Vec3b middlebury_color(double u, double v, double max_flow) {
    const auto &wheel = middlebury_wheel();
    const int ncols = static_cast<int>(wheel.size());
    const double fu = u / max_flow, fv = v / max_flow;
    const double rad = std::sqrt(fu * fu + fv * fv);
    const double a = std::atan2(-fv, -fu) / kPi;  // (-1, 1]
    const double fk = (a + 1.0) / 2.0 * (ncols - 1);
    const int k0 = std::min(static_cast<int>(fk), ncols - 1), k1 = (k0 + 1) % ncols;
    const double f = fk - k0;
    std::array<double, 3> c;
    for (int i = 0; i < 3; ++i) {
        const double col = (1 - f) * wheel[k0][i] + f * wheel[k1][i];
        c[i] = rad <= 1 ? 1 - rad * (1 - col) : col * 0.75;
    }
    return bgr(c[0], c[1], c[2]);
}

}  // namespace

cv::Vec3b flow_color(double u, double v, double max_flow, FlowColorStyle style) {
    return style == FlowColorStyle::Kitti ? kitti_color(u, v, max_flow) : middlebury_color(u, v, max_flow);
}

double flow_color_scale(const FlowField &flow, const FlowColorOptions &options) {
    require(std::isfinite(options.max_flow), ErrorCode::InvalidArgument, "flow_to_color: max_flow must be finite");
    if (options.max_flow > 0) return options.max_flow;
    const bool kitti = options.style == FlowColorStyle::Kitti;
    double max_flow = 0;
    for (int y = 0; y < flow.height(); ++y)
        for (int x = 0; x < flow.width(); ++x) {
            if (!usable(flow, y, x)) continue;
            const double u = flow.u(y, x), v = flow.v(y, x);
            max_flow = std::max(max_flow, kitti ? std::max(std::fabs(u), std::fabs(v)) : std::sqrt(u * u + v * v));
        }
    return max_flow > 0 ? max_flow : 1.0;  // all zero or nothing valid: any scale will do
}

cv::Mat flow_to_color(const FlowField &flow, const FlowColorOptions &options) {
    require(!flow.u.empty(), ErrorCode::InvalidArgument, "flow_to_color: empty flow field");
    require(flow.u.size() == flow.v.size() && flow.u.size() == flow.valid.size(), ErrorCode::SizeMismatch,
            "flow_to_color: u, v and valid differ in size");
    const bool kitti = options.style == FlowColorStyle::Kitti;
    const double max_flow = flow_color_scale(flow, options);
    cv::Mat out(flow.height(), flow.width(), CV_8UC3, cv::Scalar(0, 0, 0));
    for (int y = 0; y < flow.height(); ++y) {
        cv::Vec3b *row = out.ptr<cv::Vec3b>(y);
        for (int x = 0; x < flow.width(); ++x) {
            if (!usable(flow, y, x)) continue;
            row[x] = kitti ? kitti_color(flow.u(y, x), flow.v(y, x), max_flow)
                           : middlebury_color(flow.u(y, x), flow.v(y, x), max_flow);
        }
    }
    return out;
}

}  // namespace lidarflow::viz
