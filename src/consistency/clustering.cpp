// SPDX-License-Identifier: MIT
#include "consistency/clustering.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>
#include <vector>

#include "consistency/steps.hpp"
#include "consistency/validate.hpp"
#include "core/error.hpp"
#include "core/threads.hpp"

namespace lidarflow::consistency {

namespace {

// Union-find over pixel indices with path halving and union by size. Unions of disjoint index
// ranges may run on different threads at once (they touch only their own range).
class DisjointSets {
public:
    explicit DisjointSets(size_t n) : parent_(n), size_(n, 1) { std::iota(parent_.begin(), parent_.end(), 0); }
    int find(int i) {
        while (parent_[i] != i) {
            parent_[i] = parent_[parent_[i]];
            i = parent_[i];
        }
        return i;
    }
    // find() without path halving: safe beside other readers once every union is done.
    int root_of(int i) const {
        while (parent_[i] != i) i = parent_[i];
        return i;
    }
    void unite(int a, int b) {
        a = find(a);
        b = find(b);
        if (a == b) return;
        if (size_[a] < size_[b]) std::swap(a, b);
        parent_[b] = a;
        size_[a] += size_[b];
    }
    int size_of_root(int root) const { return size_[root]; }

private:
    std::vector<int> parent_, size_;
};

}  // namespace

ClusterResult detail::remove_small_clusters(const SceneFlowField &field, const LidarReference &lidar,
                                            const cv::Mat1b &lidar_motion_unreliable, const CheckedOptions &checked) {
    const ConsistencyOptions &opt = checked.get();
    detail::check_field(field, "clustered");
    const int h = field.height(), w = field.width();
    detail::check_size(lidar.is_lidar, h, w, "LiDAR mask");
    if (!lidar_motion_unreliable.empty()) detail::check_size(lidar_motion_unreliable, h, w, "LiDAR reliability mask");

    require(static_cast<long long>(h) * w < (1LL << 31), ErrorCode::InvalidArgument,
            "clustering: image too large");
    const int s = opt.grid_step;
    auto similar = [&](int y0, int x0, int y1, int x1) {
        return std::fabs(field.u(y0, x0) - field.u(y1, x1)) <= opt.cluster_max_flow_step &&
               std::fabs(field.v(y0, x0) - field.v(y1, x1)) <= opt.cluster_max_flow_step &&
               std::fabs(field.d0(y0, x0) - field.d0(y1, x1)) <= opt.cluster_max_disp_step &&
               std::fabs(field.d1(y0, x0) - field.d1(y1, x1)) <= opt.cluster_max_disp_step;
    };
    DisjointSets sets(static_cast<size_t>(h) * w);
    // Forward half of the neighbourhood: each pair is looked at once.
    const int dxs8[] = {s, -s, 0, s}, dys8[] = {0, s, s, s};
    const int n_dirs = opt.cluster_8_neighbours ? 4 : 2;
    const int dxs4[] = {s, 0}, dys4[] = {0, s};
    const int *dxs = opt.cluster_8_neighbours ? dxs8 : dxs4, *dys = opt.cluster_8_neighbours ? dys8 : dys4;
    // Unites (y, x) with its forward neighbours in rows [y, y_end).
    auto link = [&](int y, int x, int y_end) {
        if (!field.valid(y, x)) return;
        for (int k = 0; k < n_dirs; ++k) {
            const int nx = x + dxs[k], ny = y + dys[k];
            if (nx < 0 || nx >= w || ny >= y_end || !field.valid(ny, nx)) continue;
            if (similar(y, x, ny, nx)) sets.unite(y * w + x, ny * w + nx);
        }
    };
    // Components are the same for any thread count: each thread unites within its strip of
    // rows, then the pairs across strip borders are united in order.
    const int T = std::max(1, std::min(opt.threads, h / std::max(1, 4 * s)));
    for_each_band(h, T, [&](int, int y_begin, int y_end) {
        for (int y = y_begin; y < y_end; ++y)
            for (int x = 0; x < w; ++x) link(y, x, y_end);
    });
    for (int t = 1; t < T; ++t)
        for (int y = std::max(0, band_start(h, t, T) - s); y < band_start(h, t, T); ++y)
            for (int x = 0; x < w; ++x) link(y, x, h);

    std::vector<int> root(static_cast<size_t>(h) * w, -1);
#pragma omp parallel for schedule(static) num_threads(T)
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            if (field.valid(y, x)) root[static_cast<size_t>(y) * w + x] = sets.root_of(y * w + x);

    std::vector<unsigned char> has_reference(static_cast<size_t>(h) * w, 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool trusted = lidar.is_lidar(y, x) &&
                                 (lidar_motion_unreliable.empty() || !lidar_motion_unreliable(y, x));
            if (field.valid(y, x) && trusted) has_reference[root[static_cast<size_t>(y) * w + x]] = 1;
        }

    ClusterResult r;
    r.field = detail::empty_like(field);
    long long clusters = 0, removed_clusters = 0, removed_matches = 0;
#pragma omp parallel for schedule(static) num_threads(T) reduction(+ : clusters, removed_clusters, removed_matches)
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!field.valid(y, x)) continue;
            const int i = y * w + x, ri = root[static_cast<size_t>(i)];
            const bool big = sets.size_of_root(ri) >= opt.cluster_min_size;
            const bool keep = big || lidar.is_lidar(y, x) || (opt.keep_lidar_clusters && has_reference[ri]);
            if (i == ri) {
                ++clusters;
                if (!big && !(opt.keep_lidar_clusters && has_reference[ri])) ++removed_clusters;
            }
            if (keep)
                detail::keep_match(r.field, field, y, x);
            else
                ++removed_matches;
        }
    r.clusters = static_cast<int>(clusters);
    r.removed_clusters = static_cast<int>(removed_clusters);
    r.removed_matches = removed_matches;
    return r;
}

ClusterResult remove_small_clusters(const SceneFlowField &field, const LidarReference &lidar,
                                    const cv::Mat1b &lidar_motion_unreliable, const ConsistencyOptions &opt) {
    return detail::remove_small_clusters(field, lidar, lidar_motion_unreliable, detail::CheckedOptions(opt));
}

}  // namespace lidarflow::consistency
