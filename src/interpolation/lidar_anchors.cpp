// SPDX-License-Identifier: MIT
#include "interpolation/lidar_anchors.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lidarflow::interpolation {
namespace {

// Uniform bucket grid for nearest-point queries: a full Velodyne scan has ~20k points in the
// image and a frame ~2k superpixels, too many for brute force on the per-frame budget. The
// cells are sized for a few points each, and the search stops at the first ring beyond which
// no point can be as near as the best found.
class PointGrid {
public:
    PointGrid(const std::vector<cv::Point> &pos, const std::vector<int> &ids, int w, int h)
        : pos_(pos), cell_size_(cell_size(ids.size(), w, h)), gw_((w + cell_size_ - 1) / cell_size_),
          gh_((h + cell_size_ - 1) / cell_size_), start_(static_cast<size_t>(gw_) * gh_ + 1, 0) {
        for (int id : ids) ++start_[cell(pos[id]) + 1];
        for (size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
        items_.resize(ids.size());
        std::vector<int> fill(start_.begin(), start_.end() - 1);
        for (int id : ids) items_[fill[cell(pos[id])]++] = id;  // ids ascending -> buckets sorted
    }
    // Nearest point to (x, y), ties to the lower id; -1 when the grid is empty.
    int nearest(float x, float y) const {
        if (items_.empty()) return -1;
        const int cx = std::clamp(static_cast<int>(x) / cell_size_, 0, gw_ - 1);
        const int cy = std::clamp(static_cast<int>(y) / cell_size_, 0, gh_ - 1);
        int best = -1;
        float best_d = std::numeric_limits<float>::infinity();
        for (int r = 0; r < std::max(gw_, gh_); ++r) {
            for (int j = std::max(cy - r, 0); j <= std::min(cy + r, gh_ - 1); ++j) {
                const bool edge_row = j == cy - r || j == cy + r;
                for (int i = std::max(cx - r, 0); i <= std::min(cx + r, gw_ - 1); ++i) {
                    if (!edge_row && i != cx - r && i != cx + r) continue;  // ring only
                    for (int k = start_[j * gw_ + i]; k < start_[j * gw_ + i + 1]; ++k) {
                        const int id = items_[k];
                        const float dx = pos_[id].x - x, dy = pos_[id].y - y;
                        const float d = dx * dx + dy * dy;
                        if (d < best_d || (d == best_d && id < best)) {
                            best_d = d;
                            best = id;
                        }
                    }
                }
            }
            // A point outside the searched block lies beyond one of its sides (those inside
            // the grid), so at least that side's distance from (x, y) away.
            float reach = std::numeric_limits<float>::infinity();
            if (cx - r > 0) reach = std::min(reach, x - static_cast<float>((cx - r) * cell_size_));
            if (cx + r < gw_ - 1) reach = std::min(reach, static_cast<float>((cx + r + 1) * cell_size_) - x);
            if (cy - r > 0) reach = std::min(reach, y - static_cast<float>((cy - r) * cell_size_));
            if (cy + r < gh_ - 1) reach = std::min(reach, static_cast<float>((cy + r + 1) * cell_size_) - y);
            if (best >= 0 && (reach == std::numeric_limits<float>::infinity() || best_d < reach * reach)) break;
        }
        return best;
    }

private:
    // About four points a cell if they were spread evenly, between 8 and 64 px.
    static int cell_size(size_t points, int w, int h) {
        const double per_point = static_cast<double>(w) * h / std::max<size_t>(points, 1);
        return std::clamp(static_cast<int>(std::sqrt(4.0 * per_point)), 8, 64);
    }
    int cell(cv::Point p) const { return (p.y / cell_size_) * gw_ + p.x / cell_size_; }
    const std::vector<cv::Point> &pos_;
    int cell_size_, gw_, gh_;
    std::vector<int> start_, items_;
};

}  // namespace

LidarAnchors associate_lidar(const Superpixels &sp, const std::vector<cv::Point> &pos,
                             const std::vector<uint8_t> &is_lidar, const std::vector<uint8_t> &has_motion,
                             float max_distance) {
    std::vector<int> all, matched;
    for (int i = 0; i < static_cast<int>(pos.size()); ++i) {
        if (!is_lidar[i]) continue;
        all.push_back(i);
        if (has_motion[i]) matched.push_back(i);
    }
    LidarAnchors a = LidarAnchors::none(sp.count);
    const PointGrid grid_all(pos, all, sp.labels.cols, sp.labels.rows);
    const PointGrid grid_matched(pos, matched, sp.labels.cols, sp.labels.rows);
    const float max_d2 = max_distance * max_distance;
    auto qualifies = [&](int id, int s) {
        if (id < 0) return false;
        const float dx = pos[id].x - sp.centroid[s].x, dy = pos[id].y - sp.centroid[s].y;
        return sp.labels(pos[id].y, pos[id].x) == s || dx * dx + dy * dy <= max_d2;
    };
    for (int s = 0; s < sp.count; ++s) {
        const int g = grid_all.nearest(sp.centroid[s].x, sp.centroid[s].y);
        const int m = grid_matched.nearest(sp.centroid[s].x, sp.centroid[s].y);
        if (qualifies(g, s)) a.geometry[s] = g;
        if (qualifies(m, s)) a.motion[s] = m;
    }
    return a;
}

}  // namespace lidarflow::interpolation
