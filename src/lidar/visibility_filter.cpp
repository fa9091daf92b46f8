// SPDX-License-Identifier: MIT
#include "lidar/visibility_filter.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/bucket_lists.hpp"
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

int auto_half_height(const SparseLidar &points) {
    // Vertical gaps between consecutive points of one column; the lower quartile is the ring
    // spacing (larger gaps are columns that a ring's horizontal sampling skipped). The points
    // are visited row by row (bucketed by y), each gap taken from its column's last row; a
    // quantile does not depend on the gaps' order.
    std::vector<int> gaps;
    const auto inside = [&](const LidarPoint &p) {
        return p.x >= 0 && p.y >= 0 && p.x < points.width && p.y < points.height;
    };
    int w = 0, h = 0;  // the points' own extent: the buffers below never exceed what they cover
    for (const LidarPoint &p : points.points)
        if (inside(p)) w = std::max(w, p.x + 1), h = std::max(h, p.y + 1);
    std::vector<int> first(static_cast<size_t>(h) + 1, 0);
    for (const LidarPoint &p : points.points)
        if (inside(p)) ++first[static_cast<size_t>(p.y) + 1];
    for (int y = 0; y < h; ++y) first[y + 1] += first[y];
    std::vector<int> xs(static_cast<size_t>(first[h])), fill(first.begin(), first.end() - 1);
    for (const LidarPoint &p : points.points)
        if (inside(p)) xs[static_cast<size_t>(fill[p.y]++)] = p.x;
    std::vector<int> last(static_cast<size_t>(w), -1);  // the column's last row with a point
    for (int y = 0; y < h; ++y)
        for (int i = first[y]; i < first[y + 1]; ++i) {
            int &l = last[static_cast<size_t>(xs[static_cast<size_t>(i)])];
            if (l >= 0 && y > l) gaps.push_back(y - l);
            l = y;
        }
    // Measured on the shared KITTI scans (64, 32 and 16 of the 64 beams): lower quartiles of 5,
    // 10 and 19 px, best half heights 4, 8 and 12 px; 0.7 x the quartile gives 4, 7 and 13 px.
    if (gaps.size() < 64) return 4;
    auto q = gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 4);
    std::nth_element(gaps.begin(), q, gaps.end());
    return std::clamp(static_cast<int>(std::lround(0.7 * *q)), 1, kMaxAutoHalfHeight);
}

namespace {

// The largest disparity in each point's window (itself included), as both functions below give
// it: the dilation of the points' map (of several points on one pixel, the nearest) read at the
// points, or the same maximum over the points of the window's rows, sorted by x.
std::vector<float> window_max_by_dilation(const SparseLidar &in, int half_width, int half_height) {
    const DisparityMap map = in.to_map();
    DisparityMap nearest;
    cv::dilate(map, nearest,
               cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * half_width + 1, 2 * half_height + 1)),
               cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(kInvalidDisparity));
    std::vector<float> out(in.points.size());
    for (size_t i = 0; i < in.points.size(); ++i) out[i] = nearest(in.points[i].y, in.points[i].x);
    return out;
}

std::vector<float> window_max_by_rows(const SparseLidar &in, int half_width, int half_height) {
    const int h = in.height;
    const size_t n = in.points.size();
    const BucketLists by_row = bucket_lists(n, h, [&](size_t i, int &y0, int &y1) { y0 = y1 = in.points[i].y; });
    std::vector<std::pair<int, float>> row(n);  // (x, disparity) by row, then by x
    for (size_t k = 0; k < n; ++k) row[k] = {in.points[by_row.items[k]].x, in.points[by_row.items[k]].disparity};
    const auto first = [&](int y) { return row.begin() + static_cast<std::ptrdiff_t>(by_row.begin(y)); };
    const auto last = [&](int y) { return row.begin() + static_cast<std::ptrdiff_t>(by_row.end(y)); };
    for (int y = 0; y < h; ++y) std::sort(first(y), last(y));
    std::vector<float> out(n);
    for (size_t i = 0; i < n; ++i) {
        const LidarPoint &p = in.points[i];
        float m = kInvalidDisparity;  // what the dilation's border and empty pixels give
        for (int y = std::max(0, p.y - half_height); y <= std::min(h - 1, p.y + half_height); ++y) {
            const auto end = last(y);
            auto q = std::lower_bound(first(y), end, std::pair<int, float>(p.x - half_width, -1e30f));
            for (; q != end && q->first <= p.x + half_width; ++q) m = std::max(m, q->second);
        }
        out[i] = m;
    }
    return out;
}

}  // namespace

SparseLidar remove_hidden_points(const SparseLidar &in, const VisibilityFilterOptions &o) {
    o.validate();
    if (!o.enabled || in.points.empty()) return in;
    in.validate(in.width, in.height, "LiDAR visibility filter: points");
    // The nearest point of every window: a max filter (dilation) of the sparse disparity map,
    // whose empty pixels (kInvalidDisparity < 0) never win, or the same maxima from the points.
    const int half_height = o.half_height > 0 ? o.half_height : auto_half_height(in);
    // Rows of the window visited per point against the map's pixels: a few points read only
    // their windows' rows, a scan dilates the map.
    const double visits = static_cast<double>(in.points.size()) * (2 * half_height + 1);
    const std::vector<float> nearest = visits * 16 < static_cast<double>(in.width) * in.height
                                           ? window_max_by_rows(in, o.half_width, half_height)
                                           : window_max_by_dilation(in, o.half_width, half_height);
    SparseLidar out{in.width, in.height, {}};
    out.points.reserve(in.points.size());
    for (size_t i = 0; i < in.points.size(); ++i) {
        const LidarPoint &p = in.points[i];
        if (!(nearest[i] > p.disparity * (1.0f + o.ratio) + o.margin)) out.points.push_back(p);
    }
    return out;
}

}  // namespace lidarflow::lidar
