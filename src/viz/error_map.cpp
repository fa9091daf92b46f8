// SPDX-License-Identifier: MIT
#include "viz/error_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace lidarflow::viz {
namespace {

// Band lower bounds (in units of the outlier threshold) and their RGB colours.
struct Band {
    double lower;
    uint8_t r, g, b;
};
constexpr Band kBands[10] = {{0.0, 49, 54, 149},       {0.0625, 69, 117, 180}, {0.125, 116, 173, 209},
                             {0.25, 171, 217, 233},    {0.5, 224, 243, 248},   {1.0, 254, 224, 144},
                             {2.0, 253, 174, 97},      {4.0, 244, 109, 67},    {8.0, 215, 48, 39},
                             {16.0, 165, 0, 38}};

constexpr double kInf = std::numeric_limits<double>::infinity();

double normalised_error(double err, double gt_mag) {
    // e / |gt| / 0.05 = 20 e / |gt|; at |gt| = 0 that term is +inf (or NaN for e = 0: use e/3).
    const double rel = gt_mag > 0 ? 20.0 * err / gt_mag : kInf;
    return std::min(err / 3.0, rel);
}

cv::Vec3b linear_color(double err, bool occluded_only) {
    const auto g = static_cast<uint8_t>(std::lround(std::min(err, 5.0) / 5.0 * 255.0));
    return occluded_only ? cv::Vec3b(0, 0, g) : cv::Vec3b(g, g, g);
}

cv::Vec3b color_for(double err, double gt_mag, bool occluded_only, const ErrorImageOptions &o) {
    if (!o.log_colors) return linear_color(err, occluded_only);
    cv::Vec3b c = log_error_color(normalised_error(err, gt_mag));
    if (occluded_only)
        for (int i = 0; i < 3; ++i) c[i] = static_cast<uint8_t>(c[i] / 2);
    return c;
}

// Shared driver: err_at(y, x) returns (error, |gt|) where gt_occ is valid.
template <typename Valid, typename ErrAt>
cv::Mat paint(int rows, int cols, Valid occ_valid, Valid noc_valid, ErrAt err_at, const ErrorImageOptions &o) {
    cv::Mat out(rows, cols, CV_8UC3, cv::Scalar(0, 0, 0));
    for (int y = 0; y < rows; ++y)
        for (int x = 0; x < cols; ++x) {
            if (!occ_valid(y, x)) continue;
            const auto e = err_at(y, x);
            const cv::Vec3b c = color_for(e.first, e.second, !noc_valid(y, x), o);
            if (!o.dilate) {
                out.at<cv::Vec3b>(y, x) = c;
                continue;
            }
            for (int yy = std::max(0, y - 1); yy <= std::min(rows - 1, y + 1); ++yy)
                for (int xx = std::max(0, x - 1); xx <= std::min(cols - 1, x + 1); ++xx) out.at<cv::Vec3b>(yy, xx) = c;
        }
    return out;
}

bool flow_ok(const FlowField &f, int y, int x) {
    return f.valid(y, x) && std::isfinite(f.u(y, x)) && std::isfinite(f.v(y, x));
}

void check_flow(const FlowField &f, const char *what) {
    require(!f.u.empty(), ErrorCode::InvalidArgument, std::string("flow_error_image: empty ") + what);
    require(f.u.size() == f.v.size() && f.u.size() == f.valid.size(), ErrorCode::SizeMismatch,
            std::string("flow_error_image: u, v and valid of ") + what + " differ in size");
}

}  // namespace

cv::Vec3b log_error_color(double n) {
    int band = 0;
    for (int i = 9; i >= 0; --i)
        if (!(n < kBands[i].lower)) {  // NaN lands in the worst band
            band = i;
            break;
        }
    return {kBands[band].b, kBands[band].g, kBands[band].r};
}

cv::Mat disparity_error_image(const DisparityMap &est, const DisparityMap &gt_occ, const DisparityMap &gt_noc,
                              const ErrorImageOptions &options) {
    require(!est.empty() && !gt_occ.empty(), ErrorCode::InvalidArgument, "disparity_error_image: empty map");
    require(est.size() == gt_occ.size() && (gt_noc.empty() || gt_noc.size() == gt_occ.size()), ErrorCode::SizeMismatch,
            "disparity_error_image: estimate and ground truth differ in size");
    const DisparityMap &noc = gt_noc.empty() ? gt_occ : gt_noc;
    auto valid = [](const DisparityMap &m) {
        return [&m](int y, int x) { return disparity_valid(m(y, x)) && std::isfinite(m(y, x)); };
    };
    auto err_at = [&](int y, int x) {
        const double g = gt_occ(y, x), e = est(y, x);
        const bool ok = disparity_valid(est(y, x)) && std::isfinite(e);
        return std::make_pair(ok ? std::fabs(e - g) : kInf, std::fabs(g));
    };
    return paint(gt_occ.rows, gt_occ.cols, valid(gt_occ), valid(noc), err_at, options);
}

cv::Mat flow_error_image(const FlowField &est, const FlowField &gt_occ, const FlowField &gt_noc,
                         const ErrorImageOptions &options) {
    check_flow(est, "estimate");
    check_flow(gt_occ, "ground truth");
    const bool has_noc = !gt_noc.u.empty();
    if (has_noc) check_flow(gt_noc, "non-occluded ground truth");
    require(est.u.size() == gt_occ.u.size() && (!has_noc || gt_noc.u.size() == gt_occ.u.size()),
            ErrorCode::SizeMismatch, "flow_error_image: estimate and ground truth differ in size");
    const FlowField &noc = has_noc ? gt_noc : gt_occ;
    auto valid = [](const FlowField &f) { return [&f](int y, int x) { return flow_ok(f, y, x); }; };
    auto err_at = [&](int y, int x) {
        const double gu = gt_occ.u(y, x), gv = gt_occ.v(y, x);
        const double mag = std::sqrt(gu * gu + gv * gv);
        if (!flow_ok(est, y, x)) return std::make_pair(kInf, mag);
        const double du = est.u(y, x) - gu, dv = est.v(y, x) - gv;
        return std::make_pair(std::sqrt(du * du + dv * dv), mag);
    };
    return paint(gt_occ.height(), gt_occ.width(), valid(gt_occ), valid(noc), err_at, options);
}

}  // namespace lidarflow::viz
