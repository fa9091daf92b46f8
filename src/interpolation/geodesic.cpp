// SPDX-License-Identifier: MIT
#include "interpolation/geodesic.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "core/error.hpp"

namespace lidarflow::interp {
namespace {
// Two forward/backward sweeps: enough for the convex-ish cells of a dense seed set.
constexpr int kGeodesicPasses = 2;
}  // namespace

SeedGraph build_seed_graph(const cv::Mat1f &edges, const std::vector<cv::Point> &seeds, float edge_gain) {
    require(!edges.empty(), ErrorCode::InvalidArgument, "geodesic: empty edge map");
    require(!seeds.empty(), ErrorCode::InvalidArgument, "geodesic: no seeds");
    require(std::isfinite(edge_gain) && edge_gain >= 0.0f, ErrorCode::InvalidArgument,
            "geodesic: edge_gain must be finite and >= 0");
    const int w = edges.cols, h = edges.rows;
    const int n = static_cast<int>(seeds.size());
    SeedGraph g;
    g.nearest.create(h, w);
    g.nearest.setTo(-1);
    g.distance.create(h, w);
    g.distance.setTo(std::numeric_limits<float>::infinity());

    // Half-costs per pixel so that a step p->q costs half(p) + half(q) (symmetric).
    cv::Mat1f half(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) half(y, x) = 0.5f * (1.0f + edge_gain * edges(y, x));

    for (int i = 0; i < n; ++i) {
        const cv::Point p = seeds[i];
        require(p.x >= 0 && p.y >= 0 && p.x < w && p.y < h, ErrorCode::InvalidArgument,
                "geodesic: seed outside the edge map");
        require(g.nearest(p.y, p.x) < 0, ErrorCode::InvalidArgument, "geodesic: duplicate seed pixel");
        g.nearest(p.y, p.x) = i;
        g.distance(p.y, p.x) = 0.0f;
    }
    float *dist = g.distance.ptr<float>();
    int *lab = g.nearest.ptr<int>();
    const float *hc = half.ptr<float>();
    // Raster-scan geodesic distance transform (forward: W, NW, N, NE; backward: mirrored),
    // repeated: an O(pixels) approximation of the exact Dijkstra that differs only on paths
    // winding back more than twice, at a tenth of the cost of a pixel heap on a KITTI frame.
    constexpr float kDiag = 1.41421356f;
    auto relax = [&](int idx, int q, float len) {
        const float nd = dist[q] + len * (hc[idx] + hc[q]);
        if (nd < dist[idx]) {
            dist[idx] = nd;
            lab[idx] = lab[q];
        }
    };
    auto unreached = [&] {
        for (int i = 0; i < w * h; ++i)
            if (lab[i] < 0) return true;
        return false;
    };
    // Extra sweeps only for pathological seed layouts (a pixel still unreached).
    for (int pass = 0; pass < kGeodesicPasses || (pass < 16 && unreached()); ++pass) {
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const int idx = y * w + x;
                if (x > 0) relax(idx, idx - 1, 1.0f);
                if (y > 0) {
                    relax(idx, idx - w, 1.0f);
                    if (x > 0) relax(idx, idx - w - 1, kDiag);
                    if (x + 1 < w) relax(idx, idx - w + 1, kDiag);
                }
            }
        for (int y = h - 1; y >= 0; --y)
            for (int x = w - 1; x >= 0; --x) {
                const int idx = y * w + x;
                if (x + 1 < w) relax(idx, idx + 1, 1.0f);
                if (y + 1 < h) {
                    relax(idx, idx + w, 1.0f);
                    if (x + 1 < w) relax(idx, idx + w + 1, kDiag);
                    if (x > 0) relax(idx, idx + w - 1, kDiag);
                }
            }
    }

    // Seed links across Voronoi borders: shortest seed-to-seed path through that border.
    std::vector<std::vector<std::pair<int, float>>> links(n);
    auto link = [&](int a, int b, float wgt) {
        for (auto &e : links[a])
            if (e.first == b) {
                e.second = std::min(e.second, wgt);
                return;
            }
        links[a].emplace_back(b, wgt);
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int idx = y * w + x;
            for (int q : {x + 1 < w ? idx + 1 : -1, y + 1 < h ? idx + w : -1}) {
                if (q < 0 || lab[q] == lab[idx]) continue;
                const float wgt = dist[idx] + hc[idx] + hc[q] + dist[q];
                link(lab[idx], lab[q], wgt);
                link(lab[q], lab[idx], wgt);
            }
        }
    g.start.assign(n + 1, 0);
    for (int i = 0; i < n; ++i) g.start[i + 1] = g.start[i] + static_cast<int>(links[i].size());
    g.nbr.resize(g.start[n]);
    g.weight.resize(g.start[n]);
    for (int i = 0; i < n; ++i) {
        // Sorted by neighbour index so the graph (and every query on it) is reproducible.
        std::sort(links[i].begin(), links[i].end());
        for (size_t j = 0; j < links[i].size(); ++j) {
            g.nbr[g.start[i] + j] = links[i][j].first;
            g.weight[g.start[i] + j] = links[i][j].second;
        }
    }
    return g;
}

SeedSearch::SeedSearch(int num_seeds) : dist_(num_seeds, 0.0f), stamp_(num_seeds, 0u) {}

}  // namespace lidarflow::interp
