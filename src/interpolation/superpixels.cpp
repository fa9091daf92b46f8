// SPDX-License-Identifier: MIT
#include "interpolation/superpixels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "core/branchless.hpp"
#include "core/cpu_dispatch.hpp"
#include "core/error.hpp"
#include "core/parallel_errors.hpp"
#include "core/threads.hpp"
#include "core/union_find.hpp"

namespace lidarflow::interpolation {
namespace {

struct Centre {
    float l, a, b, x, y;
    float d = 0.0f, dw = 0.0f;  // mean disparity, and the disparity weight (0: the centre has none)
};

// Lab as three float planes (L in 0..100, a/b centred on 0) for a vectorisable inner loop;
// the 8-bit conversion is several times faster than the float one and precise enough here.
void to_lab_planes(const cv::Mat &image, cv::Mat1f planes[3]) {
    cv::Mat bgr;
    if (image.channels() == 1)
        cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    else
        bgr = image;
    cv::Mat lab8;
    cv::cvtColor(bgr, lab8, cv::COLOR_BGR2Lab);
    cv::Mat ch[3];
    cv::split(lab8, ch);
    ch[0].convertTo(planes[0], CV_32F, 100.0 / 255.0);
    ch[1].convertTo(planes[1], CV_32F, 1.0, -128.0);
    ch[2].convertTo(planes[2], CV_32F, 1.0, -128.0);
}

// Offers centre c (index k) to the pixels [x0, x1) of one row, branch-free so that it vectorises
// (core/branchless.hpp). With Depth, also c.dw * (D - c.d)^2 where V (1 valid, 0 not) is set.
template <bool Depth>
inline __attribute__((always_inline)) void assign_span_of(const float *__restrict L, const float *__restrict A,
                                                         const float *__restrict B, const float *__restrict D,
                                                         const float *__restrict V, const Centre &c, float spatial,
                                                         float dy2, int k, int x0, int x1, float *__restrict best,
                                                         int *__restrict arow) {
    const float cl = c.l, ca = c.a, cb = c.b, cx = c.x, cd = c.d, cw = c.dw;
    for (int x = x0; x < x1; ++x) {
        const float dl = L[x] - cl, da = A[x] - ca, db = B[x] - cb, sx = static_cast<float>(x) - cx;
        float d = dl * dl + da * da + db * db + spatial * sx * sx + dy2;
        if (Depth) {
            const float dd = D[x] - cd;
            d += cw * V[x] * dd * dd;
        }
        keep_first_least(d, k, best[x], arow[x]);
    }
}

// assign_span_of, cloned per ISA (clang clones no templates; each clone inlines both kinds).
LIDARFLOW_AVX2_CLONES void assign_span(bool depth, const float *__restrict L, const float *__restrict A,
                                       const float *__restrict B, const float *__restrict D,
                                       const float *__restrict V, const Centre &c, float spatial, float dy2, int k,
                                       int x0, int x1, float *__restrict best, int *__restrict arow) {
    if (depth)
        assign_span_of<true>(L, A, B, D, V, c, spatial, dy2, k, x0, x1, best, arow);
    else
        assign_span_of<false>(L, A, B, D, V, c, spatial, dy2, k, x0, x1, best, arow);
}

// First pixel of each of `cells` grid cells along a side of n pixels, pixel i lying in cell
// min(cells - 1, i / step); one more entry, n, closes the last.
std::vector<int> grid_starts(int n, int cells, float step) {
    std::vector<int> start(static_cast<size_t>(cells) + 1, n);
    for (int i = n - 1; i >= 0; --i) start[std::min(cells - 1, static_cast<int>(i / step))] = i;
    for (int c = cells - 1; c >= 0; --c) start[c] = std::min(start[c], start[c + 1]);
    return start;
}

}  // namespace

void prepare_superpixels() {
    cv::Mat1f planes[3];
    to_lab_planes(cv::Mat(1, 1, CV_8UC3, cv::Scalar::all(0)), planes);
}

// Union-find over the raster (a pixel's root is its component's first pixel): each pixel's left
// and upper neighbours are read once, where a flood fill queued every pixel and tested four.
int connected_labels(const cv::Mat1i &in, int min_size, cv::Mat1i &out) {
    require(in.total() < static_cast<size_t>(std::numeric_limits<int>::max()), ErrorCode::InvalidArgument,
            "superpixels: label map too large");
    const int w = in.cols, h = in.rows, n = w * h;
    const cv::Mat1i src = in.isContinuous() ? in : in.clone();
    const int *lab = src.ptr<int>();
    // parent[i] <= i; a root is its component's first pixel.
    std::vector<int> parent(n);
    for (int y = 0; y < h; ++y)
        for (int x = 0, i = y * w; x < w; ++x, ++i) {
            parent[i] = x > 0 && lab[i] == lab[i - 1] ? find_root(parent, i - 1) : i;
            if (y > 0 && lab[i] == lab[i - w]) unite_roots(parent, i, i - w);
        }
    // In raster order a pixel's parent, an earlier pixel, already points at its root.
    std::vector<int> size(n, 0);
    for (int i = 0; i < n; ++i) ++size[parent[i] = parent[parent[i]]];
    // Each root's label, in the roots' raster order, replaces its size.
    int next = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0, r = y * w; x < w; ++x, ++r) {
            if (parent[r] != r) continue;
            int adjacent = -1;
            for (int q : {x > 0 ? r - 1 : -1, x + 1 < w ? r + 1 : -1, y > 0 ? r - w : -1, y + 1 < h ? r + w : -1})
                if (q >= 0 && parent[q] < r) adjacent = size[parent[q]];
            size[r] = size[r] < min_size && adjacent >= 0 ? adjacent : next++;
        }
    out.create(h, w);
    int *o = out.ptr<int>();
    for (int i = 0; i < n; ++i) o[i] = size[parent[i]];
    return next;
}

Superpixels compute_superpixels(const cv::Mat &image, const SuperpixelOptions &o, const cv::Mat1f &disparity) {
    require(!image.empty(), ErrorCode::InvalidArgument, "superpixels: empty image");
    require(image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3),
            ErrorCode::InvalidArgument, "superpixels: image must be 8-bit gray or BGR");
    require(o.region_size >= 4 && o.region_size <= 512, ErrorCode::InvalidArgument,
            "superpixels: region_size must be in [4, 512]");
    require(std::isfinite(o.compactness) && o.compactness > 0.0f, ErrorCode::InvalidArgument,
            "superpixels: compactness must be > 0");
    require(o.iterations >= 1 && o.iterations <= 100, ErrorCode::InvalidArgument,
            "superpixels: iterations must be in [1, 100]");
    require(o.num_threads >= 1, ErrorCode::InvalidArgument, "superpixels: num_threads must be >= 1");
    require(std::isfinite(o.disparity_weight) && o.disparity_weight >= 0.0f && o.disparity_weight <= 1e4f,
            ErrorCode::InvalidArgument, "superpixels: disparity_weight must be in [0, 1e4]");
    require(disparity.empty() || disparity.size() == image.size(), ErrorCode::InvalidArgument,
            "superpixels: the disparity map must be of the image's size");

    const int w = image.cols, h = image.rows;
    cv::Mat1f lab[3];
    to_lab_planes(image, lab);
    // The depth planes: disparity (0 where invalid) and its validity (1 / 0).
    const bool depth = o.disparity_weight > 0.0f && !disparity.empty();
    cv::Mat1f dplane, vplane;
    if (depth) {
        dplane.create(h, w);
        vplane.create(h, w);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const float d = disparity(y, x);
                const bool ok = std::isfinite(d) && d >= 0.0f;
                dplane(y, x) = ok ? d : 0.0f;
                vplane(y, x) = ok ? 1.0f : 0.0f;
            }
    }
    const int gx = std::max(1, static_cast<int>(std::lround(static_cast<double>(w) / o.region_size)));
    const int gy = std::max(1, static_cast<int>(std::lround(static_cast<double>(h) / o.region_size)));
    const float step_x = static_cast<float>(w) / gx, step_y = static_cast<float>(h) / gy;
    std::vector<Centre> centres(static_cast<size_t>(gx) * gy);
    for (int j = 0; j < gy; ++j)
        for (int i = 0; i < gx; ++i) {
            const float cx = (i + 0.5f) * step_x, cy = (j + 0.5f) * step_y;
            const int py = std::min(h - 1, static_cast<int>(cy)), px = std::min(w - 1, static_cast<int>(cx));
            Centre &c = centres[static_cast<size_t>(j) * gx + i];
            c = {lab[0](py, px), lab[1](py, px), lab[2](py, px), cx, cy};
            if (depth && vplane(py, px) > 0.0f) {
                c.d = dplane(py, px);
                c.dw = o.disparity_weight;
            }
        }

    const std::vector<int> col_start = grid_starts(w, gx, step_x), row_start = grid_starts(h, gy, step_y);
    // Colour distances in Lab are ~0..100; SLIC's m / S balances them against pixels.
    const float spatial = (o.compactness / o.region_size) * (o.compactness / o.region_size);
    cv::Mat1i assign(h, w, 0);
    constexpr int kAcc = 8;  // L, a, b, x, y, count, disparity sum, disparity count
    std::vector<double> acc(centres.size() * kAcc);
    for (int it = 0; it < o.iterations; ++it) {
        ParallelErrors errors;
#pragma omp parallel num_threads(o.num_threads)
        {
            std::vector<float> best;
            errors.run([&] { best.resize(w); });
#pragma omp for schedule(static)
            for (int y = 0; y < h; ++y) {
                if (errors.failed()) continue;
                const int cy = std::min(gy - 1, static_cast<int>(y / step_y));
                const float *L = lab[0][y], *A = lab[1][y], *B = lab[2][y];
                const float *D = depth ? dplane[y] : nullptr, *V = depth ? vplane[y] : nullptr;
                int *arow = assign[y];
                std::fill(best.begin(), best.end(), std::numeric_limits<float>::max());
                // Centre (j, i) competes for the pixels of grid columns i-1 .. i+1: one
                // contiguous x range per centre, so the inner loop vectorises.
                for (int j = std::max(0, cy - 1); j <= std::min(gy - 1, cy + 1); ++j)
                    for (int i = 0; i < gx; ++i) {
                        const int k = j * gx + i;
                        const Centre c = centres[static_cast<size_t>(k)];
                        const int x0 = col_start[std::max(0, i - 1)], x1 = col_start[std::min(gx, i + 2)];
                        const float dy2 = spatial * (y - c.y) * (y - c.y);
                        if (depth && c.dw > 0.0f)
                            assign_span(true, L, A, B, D, V, c, spatial, dy2, k, x0, x1, best.data(), arow);
                        else
                            assign_span(false, L, A, B, D, V, c, spatial, dy2, k, x0, x1, best.data(), arow);
                    }
            }
        }
        errors.rethrow_if_any();
        std::fill(acc.begin(), acc.end(), 0.0);
        // Each thread sums the centres of a band of grid rows over the pixel rows they can hold
        // (grid rows j - 1 .. j + 1), in raster order: every centre's sums in the serial order.
        for_each_band(gy, std::min(o.num_threads, gy), [&](int, int j0, int j1) {
            const int k0 = j0 * gx, k1 = j1 * gx;
            const int y0 = j0 == 0 ? 0 : row_start[static_cast<size_t>(j0 - 1)];
            const int y1 = row_start[static_cast<size_t>(std::min(gy, j1 + 1))];
            // A run of one centre along the row adds in registers: the same additions in the
            // same order as one pixel at a time, without each waiting on the last one's store.
            // Adding +0 where a pixel has no disparity changes no sum (all start at +0).
            for (int y = y0; y < y1; ++y) {
                const int *arow = assign[y];
                const float *L = lab[0][y], *A = lab[1][y], *B = lab[2][y];
                const float *D = depth ? dplane[y] : nullptr, *V = depth ? vplane[y] : nullptr;
                for (int x = 0; x < w;) {
                    const int k = arow[x];
                    int end = x + 1;
                    while (end < w && arow[end] == k) ++end;
                    if (k >= k0 && k < k1) {
                        double *a = &acc[static_cast<size_t>(k) * kAcc];
                        double s[kAcc];
                        std::copy(a, a + kAcc, s);
                        for (int i = x; i < end; ++i) {
                            s[0] += L[i];
                            s[1] += A[i];
                            s[2] += B[i];
                            s[3] += i;
                            s[4] += y;
                            s[5] += 1.0;
                            if (depth) {
                                const bool valid = V[i] > 0.0f;
                                s[6] += valid ? D[i] : 0.0f;
                                s[7] += valid ? 1.0 : 0.0;
                            }
                        }
                        std::copy(s, s + kAcc, a);
                    }
                    x = end;
                }
            }
        });
        for (size_t k = 0; k < centres.size(); ++k) {
            const double *a = &acc[k * kAcc];
            if (a[5] <= 0.0) continue;  // an empty cluster keeps its old centre
            centres[k] = {static_cast<float>(a[0] / a[5]), static_cast<float>(a[1] / a[5]),
                          static_cast<float>(a[2] / a[5]), static_cast<float>(a[3] / a[5]),
                          static_cast<float>(a[4] / a[5])};
            if (a[7] > 0.0) {
                centres[k].d = static_cast<float>(a[6] / a[7]);
                centres[k].dw = o.disparity_weight;
            }
        }
    }

    cv::Mat1i labels;
    const int count = connected_labels(assign, std::max(1, o.region_size * o.region_size / 4), labels);
    return superpixels_from_labels(std::move(labels), count, o.num_threads);
}

Superpixels superpixels_from_labels(cv::Mat1i labels, int count, int threads) {
    require(threads >= 1 && threads <= 1024, ErrorCode::InvalidArgument, "superpixels: threads must be in [1, 1024]");
    Superpixels sp;
    sp.labels = std::move(labels);
    sp.count = count;
    const int n = count, w = sp.labels.cols, h = sp.labels.rows;
    // Row bands, one per thread, merged in band order: integer sums, the first pixel of the
    // smallest distance and sorted, unique adjacency give what one raster pass gives.
    const int T = std::max(1, std::min(threads, h));
    struct Band {
        std::vector<int64_t> sx, sy;
        std::vector<int> count;
        std::vector<float> best;
        std::vector<cv::Point> anchor;
        std::vector<std::pair<int, int>> edges;  // (label, neighbour), both ways
    };
    std::vector<Band> bands(static_cast<size_t>(T));
    for (Band &b : bands) {
        b.sx.assign(n, 0);
        b.sy.assign(n, 0);
        b.count.assign(n, 0);
        b.best.assign(n, std::numeric_limits<float>::max());
        b.anchor.assign(n, cv::Point(0, 0));
    }
    ParallelErrors errors;
    for_each_band(h, T, [&](int t, int y0, int y1) { errors.run([&] {
        Band &b = bands[static_cast<size_t>(t)];
        // A boundary runs along many pixels: skip the pair just recorded.
        const auto edge = [&b](int a, int c) {
            if (b.edges.empty() || b.edges.back() != std::make_pair(a, c)) b.edges.emplace_back(a, c);
        };
        for (int y = y0; y < y1; ++y) {
            const int *row = sp.labels.ptr<int>(y), *below = y + 1 < h ? sp.labels.ptr<int>(y + 1) : nullptr;
            for (int x = 0; x < w; ++x) {
                const int l = row[x];
                b.sx[l] += x;
                b.sy[l] += y;
                ++b.count[l];
                if (x + 1 < w && row[x + 1] != l) edge(l, row[x + 1]);
                if (below && below[x] != l) edge(l, below[x]);
            }
        }
    }); });
    errors.rethrow_if_any();
    std::vector<int64_t> sx(n, 0), sy(n, 0);
    sp.pixel_count.assign(n, 0);
    for (const Band &b : bands)
        for (int l = 0; l < n; ++l) {
            sx[l] += b.sx[l];
            sy[l] += b.sy[l];
            sp.pixel_count[l] += b.count[l];
        }
    sp.centroid.resize(n);
    for (int l = 0; l < n; ++l)
        sp.centroid[l] = cv::Point2f(static_cast<float>(static_cast<double>(sx[l]) / sp.pixel_count[l]),
                                     static_cast<float>(static_cast<double>(sy[l]) / sp.pixel_count[l]));
    // A non-convex superpixel's centroid may lie outside it; the anchor must be its own pixel.
    for_each_band(h, T, [&](int t, int y0, int y1) {
        Band &b = bands[static_cast<size_t>(t)];
        for (int y = y0; y < y1; ++y) {
            const int *row = sp.labels.ptr<int>(y);
            for (int x = 0; x < w; ++x) {
                const int l = row[x];
                const float dx = x - sp.centroid[l].x, dy = y - sp.centroid[l].y;
                const float d = dx * dx + dy * dy;
                if (d < b.best[l]) {
                    b.best[l] = d;
                    b.anchor[l] = cv::Point(x, y);
                }
            }
        }
    });
    sp.anchor.assign(n, cv::Point(0, 0));
    std::vector<float> best(n, std::numeric_limits<float>::max());
    for (const Band &b : bands)
        for (int l = 0; l < n; ++l)
            if (b.best[l] < best[l]) {
                best[l] = b.best[l];
                sp.anchor[l] = b.anchor[l];
            }
    std::vector<std::vector<int>> nb(n);
    for (const Band &b : bands)
        for (const auto &[l, m] : b.edges) {
            nb[l].push_back(m);
            nb[m].push_back(l);
        }
    set_adjacency(sp, nb);
    return sp;
}

void set_adjacency(Superpixels &sp, std::vector<std::vector<int>> &neighbours) {
    const int n = static_cast<int>(neighbours.size());
    sp.adj_start.assign(static_cast<size_t>(n) + 1, 0);
    for (int l = 0; l < n; ++l) {
        std::vector<int> &nb = neighbours[static_cast<size_t>(l)];
        std::sort(nb.begin(), nb.end());
        nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
        sp.adj_start[l + 1] = sp.adj_start[l] + static_cast<int>(nb.size());
    }
    sp.adj.clear();
    sp.adj.reserve(static_cast<size_t>(sp.adj_start[n]));
    for (const std::vector<int> &nb : neighbours) sp.adj.insert(sp.adj.end(), nb.begin(), nb.end());
}

}  // namespace lidarflow::interpolation
