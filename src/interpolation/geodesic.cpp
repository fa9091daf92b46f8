// SPDX-License-Identifier: MIT
#include "interpolation/geodesic.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <vector>

#include "core/branchless.hpp"
#include "core/bucket_lists.hpp"
#include "core/error.hpp"
#include "core/parallel_errors.hpp"
#include "core/threads.hpp"

namespace lidarflow::interpolation {
namespace {
// Two forward/backward sweeps: enough for the convex-ish cells of a dense seed set.
constexpr int kGeodesicPasses = 2;
}  // namespace

SeedGraph build_seed_graph(const cv::Mat1f &edges, const std::vector<cv::Point> &seeds, float edge_gain, int threads) {
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
    // Every step costs at least 1 (the links' keys below order the weights by their bits).
    cv::Mat1f half(h, w);
    int in_range = 1;
    for (int y = 0; y < h; ++y) {
        const float *er = edges[y];
        float *hr = half[y];
        for (int x = 0; x < w; ++x) {
            in_range &= er[x] >= 0.0f && er[x] <= std::numeric_limits<float>::max();
            hr[x] = 0.5f * (1.0f + edge_gain * er[x]);
        }
    }
    require(in_range, ErrorCode::InvalidArgument, "geodesic: edge map values must be finite and >= 0");

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
    // Raster-scan geodesic distance transform (forward: W, N, NW, NE per pixel in that order;
    // backward: mirrored), repeated: an O(pixels) approximation of the exact Dijkstra that
    // differs only on paths winding back more than twice, at a tenth of the cost of a pixel
    // heap on a KITTI frame.
    //
    // A pixel keeps the first of its candidates (its own value, then the four steps in order)
    // with the least distance. The three steps from the row before depend only on that row, so
    // their best (the first of the least among them) is found for the whole row at once, in a
    // loop the compiler vectorises; only the step along the row stays a serial scan, and its
    // result is compared with theirs after it, as the one-pixel-at-a-time order does: the same
    // distances and labels, ties included.
    constexpr float kDiag = 1.41421356f;
    std::vector<float> vdist(w);
    std::vector<int> vlab(w);
    // Best of the steps from row `from` into row `to` (straight, then towards x - s, then x + s
    // with s = +1 forward / -1 backward), into vdist / vlab.
    auto across = [&](int to, int from, int s) {
        const float *dp = dist + static_cast<size_t>(from) * w, *hp = hc + static_cast<size_t>(from) * w;
        const float *hr = hc + static_cast<size_t>(to) * w;
        const int *lp = lab + static_cast<size_t>(from) * w;
        float *vd = vdist.data();
        int *vl = vlab.data();
        const auto step = [&](int x, int q, float len, float &best, int &bl) {
            keep_first_least(dp[q] + len * (hr[x] + hp[q]), lp[q], best, bl);
        };
        const auto cell = [&](int x, bool first_diagonal, bool second_diagonal) {
            float best = dp[x] + 1.0f * (hr[x] + hp[x]);
            int bl = lp[x];
            if (first_diagonal) step(x, x - s, kDiag, best, bl);
            if (second_diagonal) step(x, x + s, kDiag, best, bl);
            vd[x] = best;
            vl[x] = bl;
        };
        const auto border = [&](int x) { cell(x, x - s >= 0 && x - s < w, x + s >= 0 && x + s < w); };
        border(0);
        if (w > 1) border(w - 1);
        for (int x = 1; x + 1 < w; ++x) cell(x, true, true);  // both diagonals exist: no branch
    };
    // The serial step along row y from x - s, then the row before's best. The previous pixel's
    // result stays in registers: reloading what was just stored made each step wait on the store.
    auto along = [&](int y, int s) {
        const size_t row = static_cast<size_t>(y) * w;
        const bool vertical = s > 0 ? y > 0 : y + 1 < h;
        float prev_d = 0.0f, prev_h = 0.0f;
        int prev_l = 0;
        for (int k = 0; k < w; ++k) {
            const int x = s > 0 ? k : w - 1 - k;
            const size_t idx = row + x;
            float best = dist[idx];
            int bl = lab[idx];
            const float hx = hc[idx];
            if (k > 0) {
                const float c = prev_d + 1.0f * (hx + prev_h);
                if (c < best) {
                    best = c;
                    bl = prev_l;
                }
            }
            if (vertical && vdist[x] < best) {
                best = vdist[x];
                bl = vlab[x];
            }
            dist[idx] = best;
            lab[idx] = bl;
            prev_d = best;
            prev_l = bl;
            prev_h = hx;
        }
    };
    auto unreached = [&] {
        for (int i = 0; i < w * h; ++i)
            if (lab[i] < 0) return true;
        return false;
    };
    // Extra sweeps only for pathological seed layouts (a pixel still unreached).
    for (int pass = 0; pass < kGeodesicPasses || (pass < 16 && unreached()); ++pass) {
        for (int y = 0; y < h; ++y) {
            if (y > 0) across(y, y - 1, 1);
            along(y, 1);
        }
        for (int y = h - 1; y >= 0; --y) {
            if (y + 1 < h) across(y, y + 1, -1);
            along(y, -1);
        }
    }

    // Seed links across Voronoi borders: for each two touching cells, the shortest seed-to-seed
    // path through a border pixel pair (a pixel and its right or lower neighbour). Each band of
    // rows lists its pairs as (lower seed, higher seed, weight), a run of one pair along the scan
    // as one entry with the least weight; the lists are bucketed by lower seed, each bucket
    // sorted by higher seed keeping the least weight, and the adjacency is filled bucket by
    // bucket in seed order, which leaves every seed's neighbours sorted by index. No step depends
    // on the order of visits: the same graph on any thread count.
    struct Link {
        int a, b;  // a < b
        float w;
    };
    const int T = std::max(1, std::min(threads, h));
    std::vector<std::vector<Link>> found(static_cast<size_t>(T));
    ParallelErrors errors;  // the bands' lists grow
    for_each_band(h, T, [&](int band, int y0, int y1) {
        errors.run([&] {
            std::vector<Link> &out = found[static_cast<size_t>(band)];
            size_t recent[2] = {SIZE_MAX, SIZE_MAX};  // the last entry of each direction
            const auto add = [&](int dir, int p, int q) {
                const int a = std::min(lab[p], lab[q]), b = std::max(lab[p], lab[q]);
                const float wgt = dist[p] + hc[p] + hc[q] + dist[q];
                const size_t r = recent[dir];
                if (r != SIZE_MAX && out[r].a == a && out[r].b == b) {
                    out[r].w = std::min(out[r].w, wgt);
                    return;
                }
                recent[dir] = out.size();
                out.push_back({a, b, wgt});
            };
            for (int y = y0; y < y1; ++y) {
                const int *lr = lab + static_cast<size_t>(y) * w;
                const int row = y * w;
                for (int x = 0; x + 1 < w; ++x)
                    if (lr[x + 1] != lr[x]) add(0, row + x, row + x + 1);
                if (y + 1 < h)
                    for (int x = 0; x < w; ++x)
                        if (lr[x + w] != lr[x]) add(1, row + x, row + x + w);
            }
        });
    });
    errors.rethrow_if_any();
    // Bucketed by lower seed (bands in order), each entry one key: the higher seed above the
    // weight's bits, which order as the weights do (non-negative floats).
    std::vector<Link> links;
    for (std::vector<Link> &band : found) {
        links.insert(links.end(), band.begin(), band.end());
        std::vector<Link>().swap(band);
    }
    const BucketLists by_lower =
        bucket_lists(links.size(), n, [&](size_t i, int &lo, int &hi) { lo = hi = links[i].a; });
    std::vector<uint64_t> bucket(links.size());
    for (size_t k = 0; k < links.size(); ++k) {
        const Link &l = links[by_lower.items[k]];
        uint32_t bits;
        std::memcpy(&bits, &l.w, sizeof bits);
        bucket[k] = static_cast<uint64_t>(l.b) << 32 | bits;
    }
    std::vector<Link>().swap(links);
    // Each bucket sorted, a neighbour's least weight (its first key) kept.
    std::vector<int> kept(static_cast<size_t>(n), 0);
#pragma omp parallel for num_threads(T) schedule(dynamic, 512)
    for (int i = 0; i < n; ++i) {
        uint64_t *out = bucket.data() + by_lower.begin(i), *end = bucket.data() + by_lower.end(i);
        std::sort(out, end);
        int k = 0;
        for (const uint64_t *e = out; e != end; ++e)
            if (k == 0 || out[k - 1] >> 32 != *e >> 32) out[k++] = *e;
        kept[i] = k;
    }
    // The adjacency: seed i's links to lower seeds come from the buckets before its own, in the
    // order of those seeds, then its own bucket's to higher seeds: sorted without a sort.
    std::vector<int> degree(static_cast<size_t>(n), 0);
    for (int i = 0; i < n; ++i) {
        degree[i] += kept[i];
        for (int j = 0; j < kept[i]; ++j) ++degree[bucket[by_lower.begin(i) + static_cast<size_t>(j)] >> 32];
    }
    g.start.assign(static_cast<size_t>(n) + 1, 0);
    for (int i = 0; i < n; ++i) g.start[i + 1] = g.start[i] + degree[i];
    g.nbr.resize(static_cast<size_t>(g.start[n]));
    g.weight.resize(static_cast<size_t>(g.start[n]));
    std::vector<int> next(g.start.begin(), g.start.end() - 1);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < kept[i]; ++j) {
            const uint64_t key = bucket[by_lower.begin(i) + static_cast<size_t>(j)];
            const int b = static_cast<int>(key >> 32);
            const uint32_t bits = static_cast<uint32_t>(key);
            float wgt;
            std::memcpy(&wgt, &bits, sizeof wgt);
            g.nbr[next[i]] = b;
            g.weight[next[i]++] = wgt;
            g.nbr[next[b]] = i;
            g.weight[next[b]++] = wgt;
        }
    return g;
}

SeedSearch::SeedSearch(int num_seeds) : dist_(num_seeds, 0.0f), stamp_(num_seeds, 0u) {}

}  // namespace lidarflow::interpolation
