// SPDX-License-Identifier: MIT
#include "interpolation/planar_merge.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <utility>

#include "core/error.hpp"
#include "core/union_find.hpp"
#include "interpolation/piecewise_model.hpp"

namespace lidarflow::interpolation {
namespace {

struct Point3 {
    float x, y, d;
};

// Whether one least-squares plane d = a x + b y + c fits every point within `tolerance`; false
// for points that do not span a plane (fewer than three, or along a line).
bool on_one_plane(const std::vector<Point3> &pts, float tolerance) {
    if (pts.size() < 3) return false;
    PlaneLsq lsq(pts[0].x, pts[0].y);
    for (const Point3 &p : pts) lsq.add(p.x, p.y, 1.0f, &p.d, 1);
    Model m;
    if (!lsq.solve(1, m)) return false;
    for (const Point3 &p : pts)
        if (!(std::fabs(m.p[0].at(p.x, p.y) - p.d) <= tolerance)) return false;
    return true;
}

// The superpixels of `labels` (sp's relabelled: old label s is now label[s], count labels), as
// superpixels_from_labels gives them, from sp's own: a label of one old superpixel keeps its
// centroid and anchor, and only the merged ones' pixels are read (sums, then the first pixel
// nearest the centroid in raster order); the adjacency is the old one's, relabelled.
Superpixels relabelled(const Superpixels &sp, const std::vector<int> &label, int count, cv::Mat1i labels) {
    const int n = sp.count, w = labels.cols, h = labels.rows;
    Superpixels m;
    m.labels = std::move(labels);
    m.count = count;
    m.parts.assign(count, 0);
    m.pixel_count.assign(count, 0);
    m.centroid.resize(count);
    m.anchor.resize(count);
    for (int s = 0; s < n; ++s) {
        const int l = label[s];
        ++m.parts[l];
        m.pixel_count[l] += sp.pixel_count[s];
        m.centroid[l] = sp.centroid[s];
        m.anchor[l] = sp.anchor[s];
    }
    std::vector<int64_t> sx(count, 0), sy(count, 0);
    for (int y = 0; y < h; ++y) {
        const int *row = m.labels.ptr<int>(y);
        for (int x = 0; x < w; ++x)
            if (m.parts[row[x]] > 1) {
                sx[row[x]] += x;
                sy[row[x]] += y;
            }
    }
    std::vector<float> best(count, std::numeric_limits<float>::max());
    for (int l = 0; l < count; ++l)
        if (m.parts[l] > 1)
            m.centroid[l] = cv::Point2f(static_cast<float>(static_cast<double>(sx[l]) / m.pixel_count[l]),
                                        static_cast<float>(static_cast<double>(sy[l]) / m.pixel_count[l]));
    for (int y = 0; y < h; ++y) {
        const int *row = m.labels.ptr<int>(y);
        for (int x = 0; x < w; ++x) {
            const int l = row[x];
            if (m.parts[l] < 2) continue;
            const float dx = x - m.centroid[l].x, dy = y - m.centroid[l].y, d = dx * dx + dy * dy;
            if (d < best[l]) {
                best[l] = d;
                m.anchor[l] = cv::Point(x, y);
            }
        }
    }
    std::vector<std::vector<int>> nb(count);
    for (int s = 0; s < n; ++s)
        for (int k = sp.adj_start[s]; k < sp.adj_start[s + 1]; ++k)
            if (label[sp.adj[k]] != label[s]) nb[label[s]].push_back(label[sp.adj[k]]);
    set_adjacency(m, nb);
    return m;
}

}  // namespace

Superpixels merge_planar_superpixels(const Superpixels &sp, const std::vector<cv::Point> &pos,
                                     const std::vector<float> &disparity, const PlanarMergeOptions &o) {
    require(pos.size() == disparity.size(), ErrorCode::InvalidArgument,
            "planar merge: one disparity per point position");
    require(std::isfinite(o.tolerance) && o.tolerance >= 0.0f, ErrorCode::InvalidArgument,
            "planar merge: tolerance must be finite and >= 0");
    require(o.min_points >= 3, ErrorCode::InvalidArgument, "planar merge: min_points must be >= 3");
    require(o.threads >= 1 && o.threads <= 1024, ErrorCode::InvalidArgument, "planar merge: threads must be in [1, 1024]");
    if ((o.tolerance <= 0.0f && !o.unseen) || o.max_area <= 0 || sp.count < 2) return sp;
    const int n = sp.count, w = sp.labels.cols, h = sp.labels.rows;
    // The points per superpixel; only their presence where no plane is tested.
    const bool planes = o.tolerance > 0.0f;
    std::vector<std::vector<Point3>> pts(n);
    std::vector<int> held(n, 0);
    for (size_t i = 0; i < pos.size(); ++i) {
        const cv::Point p = pos[i];
        if (p.x < 0 || p.y < 0 || p.x >= w || p.y >= h || !std::isfinite(disparity[i])) continue;
        const int l = sp.labels(p.y, p.x);
        ++held[l];
        if (planes) pts[l].push_back({static_cast<float>(p.x), static_cast<float>(p.y), disparity[i]});
    }
    std::vector<int> parent(n), area(sp.pixel_count);
    std::iota(parent.begin(), parent.end(), 0);
    // Planar: enough points, on one plane. Unseen: no point in it nor in a neighbour (sky, the
    // image above the scan), where small superpixels have no LiDAR boundary to follow.
    std::vector<uint8_t> planar(n), unseen(n);
    for (int s = 0; s < n; ++s) {
        planar[s] = planes && held[s] >= o.min_points && on_one_plane(pts[s], o.tolerance);
        unseen[s] = o.unseen && held[s] == 0;
        for (int k = sp.adj_start[s]; k < sp.adj_start[s + 1] && unseen[s]; ++k) unseen[s] = held[sp.adj[k]] == 0;
    }
    std::vector<Point3> both;
    for (int s = 0; s < n; ++s)
        for (int k = sp.adj_start[s]; k < sp.adj_start[s + 1]; ++k) {
            const int t = sp.adj[k];
            if (t < s) continue;  // each pair once, in label order
            const int rs = find_root(parent, s), rt = find_root(parent, t);
            if (rs == rt || area[rs] + area[rt] > o.max_area) continue;
            // A region is all unseen or all planar (unseen superpixels hold no points).
            if (!(unseen[s] && unseen[t])) {
                if (!planar[rs] || !planar[rt]) continue;
                both = pts[rs];
                both.insert(both.end(), pts[rt].begin(), pts[rt].end());
                if (!on_one_plane(both, o.tolerance)) continue;
            }
            const int root = std::min(rs, rt), other = std::max(rs, rt);
            parent[other] = root;
            area[root] += area[other];
            if (!(unseen[s] && unseen[t])) pts[root].swap(both);
            pts[other].clear();
        }
    // Renumber: new labels in order of each region's smallest old label (its root).
    std::vector<int> label(n, -1);
    int count = 0;
    for (int s = 0; s < n; ++s) {
        const int r = find_root(parent, s);
        if (label[r] < 0) label[r] = count++;
        label[s] = label[r];
    }
    if (count == n) return sp;
    cv::Mat1i labels(h, w);
#pragma omp parallel for num_threads(o.threads) schedule(static)
    for (int y = 0; y < h; ++y) {
        const int *in = sp.labels.ptr<int>(y);
        int *out = labels.ptr<int>(y);
        for (int x = 0; x < w; ++x) out[x] = label[in[x]];
    }
    return relabelled(sp, label, count, std::move(labels));
}

}  // namespace lidarflow::interpolation
