// SPDX-License-Identifier: MIT
#include "viz/disparity_color.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace lidarflow::viz {
namespace {

// Control colours (RGB) and the relative length of the segment that starts at each, as in the
// devkit's map; the last colour closes the ramp.
constexpr double kStops[8][4] = {{0, 0, 0, 114}, {0, 0, 1, 185}, {1, 0, 0, 114}, {1, 0, 1, 174},
                                 {0, 1, 0, 114}, {0, 1, 1, 185}, {1, 1, 0, 114}, {1, 1, 1, 0}};

cv::Vec3b ramp(double t) {
    double total = 0;
    for (int i = 0; i < 7; ++i) total += kStops[i][3];
    double start = 0;
    int seg = 0;
    // Segment containing t (the last one takes t == 1).
    for (; seg < 6; ++seg) {
        const double end = start + kStops[seg][3] / total;
        if (t <= end) break;
        start = end;
    }
    const double f = std::min(std::max((t - start) / (kStops[seg][3] / total), 0.0), 1.0);
    cv::Vec3b out;
    for (int c = 0; c < 3; ++c) {
        const double v = (1 - f) * kStops[seg][c] + f * kStops[seg + 1][c];
        out[2 - c] = static_cast<uint8_t>(std::lround(std::min(std::max(v, 0.0), 1.0) * 255.0));
    }
    return out;
}

}  // namespace

double disparity_color_scale(const DisparityMap &disp, float max_disp) {
    require(std::isfinite(max_disp), ErrorCode::InvalidArgument, "disparity_to_color: max_disp must be finite");
    if (max_disp > 0) return max_disp;
    double max_d = 0;
    for (int y = 0; y < disp.rows; ++y)
        for (int x = 0; x < disp.cols; ++x)
            if (disparity_valid(disp(y, x)) && std::isfinite(disp(y, x))) max_d = std::max(max_d, double(disp(y, x)));
    return max_d > 0 ? max_d : 1.0;
}

cv::Vec3b disparity_color(double d, double max_disp) { return ramp(std::min(std::max(d / max_disp, 0.0), 1.0)); }

cv::Mat disparity_to_color(const DisparityMap &disp, float max_disp) {
    require(!disp.empty(), ErrorCode::InvalidArgument, "disparity_to_color: empty disparity map");
    const double max_d = disparity_color_scale(disp, max_disp);
    cv::Mat out(disp.rows, disp.cols, CV_8UC3, cv::Scalar(0, 0, 0));
    for (int y = 0; y < disp.rows; ++y) {
        cv::Vec3b *row = out.ptr<cv::Vec3b>(y);
        for (int x = 0; x < disp.cols; ++x) {
            const float d = disp(y, x);
            if (!disparity_valid(d)) continue;  // NaN fails too
            row[x] = ramp(std::isfinite(d) ? std::min(d / max_d, 1.0) : 1.0);
        }
    }
    return out;
}

}  // namespace lidarflow::viz
