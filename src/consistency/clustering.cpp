// SPDX-License-Identifier: MIT
#include "consistency/clustering.hpp"

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <numeric>
#include <utility>
#include <vector>

#include "consistency/steps.hpp"
#include "consistency/validate.hpp"
#include "core/cpu_dispatch.hpp"
#include "core/error.hpp"
#include "core/parallel_errors.hpp"
#include "core/threads.hpp"
#include "core/union_find.hpp"

namespace lidarflow::consistency {

namespace {

// Pixels are united by core/union_find.hpp. A pixel is linked only to earlier ones, so a set
// made inside one band of rows keeps every parent inside that band: bands may link at the same
// time.

// The links of row y to its earlier neighbours (left, and up-left, up, up-right with 8
// neighbours; left and up with 4), one bit each per pixel, computed for a whole row at a time
// without branches on the values so that the comparisons vectorise.
enum Link : uint8_t { kLeft = 1, kUpLeft = 2, kUp = 4, kUpRight = 8 };

struct Planes {
    const float *u, *v, *d0, *d1;
    const uint8_t *valid;
};

Planes row_of(const SceneFlowField &f, int y) {
    return {f.u[y], f.v[y], f.d0[y], f.d1[y], f.valid[y]};
}

// bit |= joined(a[x], b[x + db]) for x in [x0, x1).
LIDARFLOW_AVX2_CLONES void add_links(const Planes &a, const Planes &b, int db, int x0, int x1, float flow_step,
                                     float disp_step, uint8_t bit, uint8_t *__restrict links) {
    const float *__restrict au = a.u, *__restrict av = a.v, *__restrict ad0 = a.d0, *__restrict ad1 = a.d1;
    const float *__restrict bu = b.u + db, *__restrict bv = b.v + db, *__restrict bd0 = b.d0 + db,
                            *__restrict bd1 = b.d1 + db;
    const uint8_t *__restrict avalid = a.valid, *__restrict bvalid = b.valid + db;
    for (int x = x0; x < x1; ++x) {
        // Bitwise on ints, not short-circuit: no branch in the loop.
        const int j = int{avalid[x] != 0} & int{bvalid[x] != 0} & int{std::fabs(au[x] - bu[x]) <= flow_step} &
                      int{std::fabs(av[x] - bv[x]) <= flow_step} & int{std::fabs(ad0[x] - bd0[x]) <= disp_step} &
                      int{std::fabs(ad1[x] - bd1[x]) <= disp_step};
        links[x] = static_cast<uint8_t>(links[x] | (j ? bit : 0));
    }
}

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
    const bool eight = opt.cluster_8_neighbours;
    const float tf = opt.cluster_max_flow_step, td = opt.cluster_max_disp_step;
    std::vector<int> parent(static_cast<size_t>(h) * w);
    // Row y's links: to its left neighbour (with `left`) and to row y - s (with `up`).
    auto row_links = [&](int y, bool left, bool up, std::vector<uint8_t> &links) {
        std::fill(links.begin(), links.end(), 0);
        const Planes row = row_of(field, y);
        if (left && s < w) add_links(row, row, -s, s, w, tf, td, kLeft, links.data());
        if (!up) return;
        const Planes above = row_of(field, y - s);
        add_links(row, above, 0, 0, w, tf, td, kUp, links.data());
        if (eight && s < w) {
            add_links(row, above, -s, s, w, tf, td, kUpLeft, links.data());
            add_links(row, above, s, 0, w - s, tf, td, kUpRight, links.data());
        }
    };
    // Unites each pixel of row y with the neighbours its links name; a pixel still on its own
    // takes its first neighbour's root as parent (an earlier pixel: parents stay below their index).
    auto unite_row = [&](int y, const std::vector<uint8_t> &links) {
        for (int x = 0, i = y * w; x < w; ++x, ++i) {
            const uint8_t l = links[static_cast<size_t>(x)];
            if (!l) continue;
            const int nb[4] = {i - s, i - s * w - s, i - s * w, i - s * w + s};  // kLeft .. kUpRight
            for (int k = 0; k < 4; ++k) {
                if (!(l & (1 << k))) continue;
                if (parent[static_cast<size_t>(i)] == i)
                    parent[static_cast<size_t>(i)] = find_root(parent, nb[k]);
                else
                    unite_roots(parent, i, nb[k]);
            }
        }
    };
    // Components are the same for any thread count (they are the field's): each thread links
    // the rows of its strip within it, then the first rows of each strip link to the strip before.
    const int T = std::max(1, std::min(opt.threads, h / std::max(1, 4 * s)));
    ParallelErrors errors;
    for_each_band(h, T, [&](int, int y_begin, int y_end) {
        errors.run([&] {
            std::vector<uint8_t> links(static_cast<size_t>(w));
            for (int y = y_begin; y < y_end; ++y) {
                std::iota(parent.begin() + static_cast<std::ptrdiff_t>(y) * w,
                          parent.begin() + static_cast<std::ptrdiff_t>(y + 1) * w, y * w);
                row_links(y, true, y - s >= y_begin, links);
                unite_row(y, links);
            }
        });
    });
    errors.rethrow_if_any();
    std::vector<uint8_t> links(static_cast<size_t>(w));
    for (int t = 1; t < T; ++t)
        for (int y = band_start(h, t, T); y < std::min(h, band_start(h, t, T) + s); ++y) {
            row_links(y, false, true, links);
            unite_row(y, links);
        }

    // Each pixel's root, then each root's count: a pixel's parent is an earlier (valid) pixel
    // whose root this raster pass already knows.
    std::vector<int> root(static_cast<size_t>(h) * w, -1), size(static_cast<size_t>(h) * w, 0);
    for (int y = 0; y < h; ++y) {
        const uint8_t *valid = field.valid[y];
        for (int x = 0, i = y * w; x < w; ++x, ++i) {
            if (!valid[x]) continue;
            const int p = parent[static_cast<size_t>(i)];
            root[static_cast<size_t>(i)] = p == i ? i : root[static_cast<size_t>(p)];
            ++size[static_cast<size_t>(root[static_cast<size_t>(i)])];
        }
    }

    std::vector<unsigned char> has_reference(static_cast<size_t>(h) * w, 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool trusted = lidar.is_lidar(y, x) &&
                                 (lidar_motion_unreliable.empty() || !lidar_motion_unreliable(y, x));
            if (field.valid(y, x) && trusted) has_reference[root[static_cast<size_t>(y) * w + x]] = 1;
        }

    ClusterResult r;
    r.field = SceneFlowField::uninitialized(w, h);  // each row cleared where it is filled
    long long clusters = 0, removed_clusters = 0, removed_matches = 0;
#pragma omp parallel for schedule(static) num_threads(T) reduction(+ : clusters, removed_clusters, removed_matches)
    for (int y = 0; y < h; ++y) {
        r.field.clear_row(y);
        for (int x = 0; x < w; ++x) {
            if (!field.valid(y, x)) continue;
            const int i = y * w + x, ri = root[static_cast<size_t>(i)];
            const bool big = size[static_cast<size_t>(ri)] >= opt.cluster_min_size;
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
