// SPDX-License-Identifier: MIT
#include "interpolation/lidar_anchors.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lidarflow::interpolation {
namespace {

// Uniform bucket grid for nearest-point queries: a full Velodyne scan has ~20k points in the
// image and a frame ~2k superpixels, too many for brute force on the per-frame budget.
class PointGrid {
public:
    PointGrid(const std::vector<cv::Point> &pos, const std::vector<int> &ids, int w, int h)
        : pos_(pos), gw_((w + kCell - 1) / kCell), gh_((h + kCell - 1) / kCell), start_(gw_ * gh_ + 1, 0) {
        for (int id : ids) ++start_[cell(pos[id]) + 1];
        for (size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
        items_.resize(ids.size());
        std::vector<int> fill(start_.begin(), start_.end() - 1);
        for (int id : ids) items_[fill[cell(pos[id])]++] = id;  // ids ascending -> buckets sorted
    }
    // Nearest point to (x, y) or -1 when the grid is empty.
    int nearest(float x, float y) const {
        if (items_.empty()) return -1;
        const int cx = std::clamp(static_cast<int>(x) / kCell, 0, gw_ - 1);
        const int cy = std::clamp(static_cast<int>(y) / kCell, 0, gh_ - 1);
        int best = -1;
        float best_d = std::numeric_limits<float>::infinity();
        for (int r = 0; r < std::max(gw_, gh_); ++r) {
            for (int j = cy - r; j <= cy + r; ++j) {
                if (j < 0 || j >= gh_) continue;
                for (int i = cx - r; i <= cx + r; ++i) {
                    if (i < 0 || i >= gw_) continue;
                    if (std::max(std::abs(i - cx), std::abs(j - cy)) != r) continue;  // ring only
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
            // Any point in ring r+1 or beyond is at least r cells away from (x, y).
            const float reach = static_cast<float>(r * kCell);
            if (best >= 0 && best_d <= reach * reach) break;
        }
        return best;
    }

private:
    static constexpr int kCell = 32;
    int cell(cv::Point p) const { return (p.y / kCell) * gw_ + p.x / kCell; }
    const std::vector<cv::Point> &pos_;
    int gw_, gh_;
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
