// SPDX-License-Identifier: MIT
#include "interpolation/geodesic.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "core/branchless.hpp"
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

    // Seed links across Voronoi borders: shortest seed-to-seed path through that border. Each
    // band of rows links the border pixel pairs that start in it (a pixel and its right or lower
    // neighbour), into its own slots per seed, sized by those pairs (an upper bound on the seed's
    // distinct neighbours there); a seed's lists from all bands are then merged, the least
    // weight of a neighbour kept: the least over every border pixel pair, as one scan gives.
    const int T = std::max(1, std::min(threads, h));
    struct BandLinks {
        std::vector<int> cap, used;
        std::vector<std::pair<int, float>> slots;
    };
    std::vector<BandLinks> bands(static_cast<size_t>(T));
    ParallelErrors errors;  // the bands allocate
    for_each_band(h, T, [&](int band, int y0, int y1) {
        errors.run([&] {
            BandLinks &L = bands[static_cast<size_t>(band)];
            // visit(p, q, vertical) for each 4-neighbour pixel pair across a border, p in the band.
            auto each_border = [&](auto &&visit) {
                for (int y = y0; y < y1; ++y) {
                    const int *lr = lab + static_cast<size_t>(y) * w;
                    for (int x = 0; x < w; ++x) {
                        if (x + 1 < w && lr[x + 1] != lr[x]) visit(y * w + x, y * w + x + 1, 0);
                        if (y + 1 < h && lr[x + w] != lr[x]) visit(y * w + x, (y + 1) * w + x, 1);
                    }
                }
            };
            L.cap.assign(static_cast<size_t>(n) + 1, 0);
            each_border([&](int p, int q, int) {
                ++L.cap[lab[p] + 1];
                ++L.cap[lab[q] + 1];
            });
            for (int i = 0; i < n; ++i) L.cap[i + 1] += L.cap[i];
            L.slots.resize(static_cast<size_t>(L.cap[n]));
            L.used.assign(static_cast<size_t>(n), 0);
            // a's link to b, with the least weight so far (slots do not move: the pointer stays valid).
            auto link = [&](int a, int b, float wgt) {
                std::pair<int, float> *first = L.slots.data() + L.cap[a], *last = first + L.used[a];
                for (std::pair<int, float> *e = first; e != last; ++e)
                    if (e->first == b) {
                        e->second = std::min(e->second, wgt);
                        return e;
                    }
                *last = {b, wgt};
                ++L.used[a];
                return last;
            };
            // A border runs on along a row or a column: the pair of the previous pixel pair of the
            // same direction is usually this one's, and its links need no search.
            struct Recent {
                int a = -1, b = -1;
                std::pair<int, float> *ab = nullptr, *ba = nullptr;
            } recent[2];
            each_border([&](int p, int q, int vertical) {
                const float wgt = dist[p] + hc[p] + hc[q] + dist[q];
                Recent &r = recent[vertical];
                if (lab[p] == r.a && lab[q] == r.b) {
                    r.ab->second = std::min(r.ab->second, wgt);
                    r.ba->second = std::min(r.ba->second, wgt);
                    return;
                }
                r = {lab[p], lab[q], link(lab[p], lab[q], wgt), link(lab[q], lab[p], wgt)};
            });
        });
    });
    errors.rethrow_if_any();
    // Each seed's lists from all bands, sorted by neighbour index (so that the graph, and every
    // query on it, is reproducible), a neighbour's least weight kept: first into slots sized by
    // the bands' counts, then packed.
    std::vector<int> upper(static_cast<size_t>(n) + 1, 0), count(static_cast<size_t>(n), 0);
    for (int i = 0; i < n; ++i) {
        int c = 0;
        for (const BandLinks &L : bands) c += L.used[static_cast<size_t>(i)];
        upper[i + 1] = upper[i] + c;
    }
    std::vector<std::pair<int, float>> merged(static_cast<size_t>(upper[n]));
#pragma omp parallel for num_threads(T) schedule(static)
    for (int i = 0; i < n; ++i) {
        std::pair<int, float> *out = merged.data() + upper[i], *end = out;
        for (const BandLinks &L : bands) {
            const std::pair<int, float> *first = L.slots.data() + L.cap[i];
            end = std::copy(first, first + L.used[static_cast<size_t>(i)], end);
        }
        std::sort(out, end);
        int k = 0;
        for (const std::pair<int, float> *e = out; e != end; ++e)
            if (k > 0 && out[k - 1].first == e->first)
                out[k - 1].second = std::min(out[k - 1].second, e->second);
            else
                out[k++] = *e;
        count[i] = k;
    }
    g.start.assign(static_cast<size_t>(n) + 1, 0);
    for (int i = 0; i < n; ++i) g.start[i + 1] = g.start[i] + count[i];
    g.nbr.resize(static_cast<size_t>(g.start[n]));
    g.weight.resize(static_cast<size_t>(g.start[n]));
#pragma omp parallel for num_threads(T) schedule(static)
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < count[i]; ++j) {
            g.nbr[g.start[i] + j] = merged[static_cast<size_t>(upper[i] + j)].first;
            g.weight[g.start[i] + j] = merged[static_cast<size_t>(upper[i] + j)].second;
        }
    return g;
}

SeedSearch::SeedSearch(int num_seeds) : dist_(num_seeds, 0.0f), stamp_(num_seeds, 0u) {}

}  // namespace lidarflow::interpolation
