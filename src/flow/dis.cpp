// SPDX-License-Identifier: MIT
#include "flow/dis.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/cpu_dispatch.hpp"
#include "core/error.hpp"

// Built with -ffp-contract=off (src/CMakeLists.txt): every product and sum is rounded on its own,
// as in OpenCV's build, or the flow would differ from OpenCV's in the last bits.

namespace lidarflow::flow {
namespace {

constexpr float kEps = 0.001f;
constexpr float kInf = 1e10f;
// OpenCV's border of I1: a moved patch is clamped to start at most a patch minus one outside it,
// and to end at most a patch past it. Up to 16 px OpenCV reads only that border; the 32 px kept
// here cover every allowed patch size, with the same clamps and so the same flows.
constexpr int kBorder = 16;
constexpr int kPad = 32;
constexpr int kStripes = 8;  // fixed, so that the propagation (inside a stripe) is thread-independent

// One search's view of a level: the image searched from (I0) and in (I1), and the initial flow.
struct Level {
    cv::Mat1f f0;              // I0 as float (a view into its padded plane)
    cv::Mat1f gx, gy;          // I0's Sobel gradients (cv::spatialGradient) as float, f0's row step
    cv::Mat1f f1;              // I1 with a replicated border of kPad, as float
    cv::Mat1f init_u, init_v;  // the initial flow at this level (empty without one)
    int w() const { return f0.cols; }
    int h() const { return f0.rows; }
    const float *f1_at(int y, int x) const { return f1.ptr<float>(y + kPad) + x + kPad; }
    // In OpenCV's bordered coordinates (pixel (0, 0) at (kBorder, kBorder)).
    const float *f1_bordered(int y, int x) const { return f1.ptr<float>(y + kPad - kBorder) + x + kPad - kBorder; }
};

// Per patch of the grid (ws x hs, row-major): the structure tensor and the gradient sums.
struct Tensor {
    std::vector<float> xx, yy, xy, x, y;
};

// OpenCV's separable box sums over patch_size, sampled every patch_stride, in its order.
Tensor structure_tensor(const Level &l, int psz, int pstr, int ws, int hs, const cv::Mat1s &ix, const cv::Mat1s &iy) {
    const int w = l.w(), h = l.h();
    const size_t aux_n = static_cast<size_t>(h) * ws;
    std::vector<float> axx(aux_n), ayy(aux_n), axy(aux_n), ax(aux_n), ay(aux_n);
    for (int i = 0; i < h; ++i) {
        float sxx = 0.0f, syy = 0.0f, sxy = 0.0f, sx = 0.0f, sy = 0.0f;
        const short *xr = ix.ptr<short>(i), *yr = iy.ptr<short>(i);
        for (int j = 0; j < psz; ++j) {
            sxx += xr[j] * xr[j];
            syy += yr[j] * yr[j];
            sxy += xr[j] * yr[j];
            sx += xr[j];
            sy += yr[j];
        }
        size_t at = static_cast<size_t>(i) * ws;
        axx[at] = sxx, ayy[at] = syy, axy[at] = sxy, ax[at] = sx, ay[at] = sy;
        int js = 1;
        for (int j = psz; j < w; ++j) {
            sxx += (xr[j] * xr[j] - xr[j - psz] * xr[j - psz]);
            syy += (yr[j] * yr[j] - yr[j - psz] * yr[j - psz]);
            sxy += (xr[j] * yr[j] - xr[j - psz] * yr[j - psz]);
            sx += (xr[j] - xr[j - psz]);
            sy += (yr[j] - yr[j - psz]);
            if ((j - psz + 1) % pstr == 0) {
                at = static_cast<size_t>(i) * ws + js;
                axx[at] = sxx, ayy[at] = syy, axy[at] = sxy, ax[at] = sx, ay[at] = sy;
                ++js;
            }
        }
    }
    Tensor t;
    const size_t n = static_cast<size_t>(ws) * hs;
    for (auto *v : {&t.xx, &t.yy, &t.xy, &t.x, &t.y}) v->assign(n, 0.0f);
    std::vector<float> sxx(ws, 0.0f), syy(ws, 0.0f), sxy(ws, 0.0f), sx(ws, 0.0f), sy(ws, 0.0f);
    for (int i = 0; i < psz; ++i)
        for (int j = 0; j < ws; ++j) {
            const size_t a = static_cast<size_t>(i) * ws + j;
            sxx[j] += axx[a], syy[j] += ayy[a], sxy[j] += axy[a], sx[j] += ax[a], sy[j] += ay[a];
        }
    for (int j = 0; j < ws; ++j) t.xx[j] = sxx[j], t.yy[j] = syy[j], t.xy[j] = sxy[j], t.x[j] = sx[j], t.y[j] = sy[j];
    int is = 1;
    for (int i = psz; i < h; ++i) {
        for (int j = 0; j < ws; ++j) {
            const size_t a = static_cast<size_t>(i) * ws + j, b = static_cast<size_t>(i - psz) * ws + j;
            sxx[j] += (axx[a] - axx[b]);
            syy[j] += (ayy[a] - ayy[b]);
            sxy[j] += (axy[a] - axy[b]);
            sx[j] += (ax[a] - ax[b]);
            sy[j] += (ay[a] - ay[b]);
        }
        if ((i - psz + 1) % pstr == 0) {
            const size_t o = static_cast<size_t>(is) * ws;
            for (int j = 0; j < ws; ++j)
                t.xx[o + j] = sxx[j], t.yy[o + j] = syy[j], t.xy[o + j] = sxy[j], t.x[o + j] = sx[j], t.y[o + j] = sy[j];
            ++is;
        }
    }
    return t;
}

// The bilinear weights of I1 at a patch moved by (u, v), and the top-left sample, as OpenCV
// computes them (its clamps keep every read inside the border).
struct Bilinear {
    float w00, w01, w10, w11;
    const float *at;  // I1 (bordered) at the patch's top-left sample
};

inline __attribute__((always_inline)) Bilinear bilinear(const Level &l, int i, int j, float u, float v, int psz) {
    const float lo = static_cast<float>(kBorder - psz + 1);
    const float hi_i = static_cast<float>(kBorder + l.h() - 1), hi_j = static_cast<float>(kBorder + l.w() - 1);
    const float ii = std::min(std::max(static_cast<float>(i) + v + static_cast<float>(kBorder), lo), hi_i);
    const float jj = std::min(std::max(static_cast<float>(j) + u + static_cast<float>(kBorder), lo), hi_j);
    const float fi = std::floor(ii), fj = std::floor(jj);
    Bilinear b;
    b.w11 = (ii - fi) * (jj - fj);
    b.w10 = (ii - fi) * (fj + 1 - jj);
    b.w01 = (fi + 1 - ii) * (jj - fj);
    b.w00 = (fi + 1 - ii) * (fj + 1 - jj);
    b.at = l.f1_bordered(static_cast<int>(ii), static_cast<int>(jj));
    return b;
}

// Sums of one patch comparison with mean normalisation: the SSD (always) and, with Grad, the
// gradient products for a descent step. The 8 px kernel keeps OpenCV's 4-lane order (a row's
// left and right half added lane by lane, lanes summed (0 + 2) + (1 + 3) at the end) in vectors
// of 8 (a whole row: one AVX operation where the clone has AVX); other sizes sum pixel by pixel
// in the order of OpenCV's scalar code (under 8 px with each row's products in one 8-lane step).
struct PatchSums {
    float diff = 0.0f, sq = 0.0f, gx = 0.0f, gy = 0.0f;
};

typedef float V8 __attribute__((vector_size(32)));
typedef float V4 __attribute__((vector_size(16)));

inline __attribute__((always_inline)) V8 load8(const float *p) {
    V8 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline __attribute__((always_inline)) void store8(float *p, V8 v) { std::memcpy(p, &v, sizeof v); }
inline __attribute__((always_inline)) V8 splat8(float x) { return V8{x, x, x, x, x, x, x, x}; }
typedef int I8 __attribute__((vector_size(32)));
// Lane by lane `m ? a : b` (m: a comparison's all-ones or zero lanes).
inline __attribute__((always_inline)) V8 select(I8 m, V8 a, V8 b) { return reinterpret_cast<V8>((reinterpret_cast<I8>(a) & m) | (reinterpret_cast<I8>(b) & ~m)); }
inline __attribute__((always_inline)) V8 abs8(V8 a) { return reinterpret_cast<V8>(reinterpret_cast<I8>(a) & 0x7fffffff); }
inline __attribute__((always_inline)) bool all_equal(I8 a, I8 b) {
    const I8 m = a == b;
    int all = -1;
    for (int k = 0; k < 8; ++k) all &= m[k];
    return all != 0;
}
inline __attribute__((always_inline)) V4 halves(V8 v) { return V4{v[0], v[1], v[2], v[3]} + V4{v[4], v[5], v[6], v[7]}; }
inline __attribute__((always_inline)) float lanes(V4 a) { return (a[0] + a[2]) + (a[1] + a[3]); }

template <bool Grad>
inline __attribute__((always_inline)) PatchSums patch8(const float *i0, size_t s0, const float *gx, const float *gy,
                                                      const Bilinear &b, size_t s1) {
    const V8 w00 = splat8(b.w00), w01 = splat8(b.w01), w10 = splat8(b.w10), w11 = splat8(b.w11);
    V4 sd{}, sq{}, sx{}, sy{};
    const float *r1 = b.at;
    V8 top = load8(r1), tops = load8(r1 + 1);
    for (int r = 0; r < 8; ++r, i0 += s0) {
        r1 += s1;
        const V8 bot = load8(r1), bots = load8(r1 + 1);
        const V8 d = w00 * top + w01 * tops + w10 * bot + w11 * bots - load8(i0);
        if (Grad) {
            sx += halves(d * load8(gx));
            sy += halves(d * load8(gy));
            gx += s0, gy += s0;
        }
        sq += halves(d * d);
        sd += halves(d);
        top = bot, tops = bots;
    }
    PatchSums p;
    p.diff = lanes(sd), p.sq = lanes(sq);
    if (Grad) p.gx = lanes(sx), p.gy = lanes(sy);
    return p;
}

template <bool Grad>
inline __attribute__((always_inline)) PatchSums patch_any(const float *i0, size_t s0, const float *gx, const float *gy,
                                                         const Bilinear &b, size_t s1, int psz) {
    PatchSums p;
    for (int i = 0; i < psz; ++i) {
        const float *r1 = b.at + i * s1, *n1 = r1 + s1, *a0 = i0 + i * s0;
        for (int j = 0; j < psz; ++j) {
            const float d = b.w00 * r1[j] + b.w01 * r1[j + 1] + b.w10 * n1[j] + b.w11 * n1[j + 1] - a0[j];
            p.diff += d;
            p.sq += d * d;
            if (Grad) {
                p.gx += d * gx[i * s0 + j];
                p.gy += d * gy[i * s0 + j];
            }
        }
    }
    return p;
}

// patch_any for patches of at most 8 px: a row's differences and products in one 8-lane step
// (the planes' borders hold the lanes past the patch), then added pixel by pixel in its order.
template <bool Grad>
inline __attribute__((always_inline)) PatchSums patch_small(const float *i0, size_t s0, const float *gx,
                                                           const float *gy, const Bilinear &b, size_t s1, int psz) {
    const V8 w00 = splat8(b.w00), w01 = splat8(b.w01), w10 = splat8(b.w10), w11 = splat8(b.w11);
    PatchSums p;
    const float *r1 = b.at;
    V8 top = load8(r1), tops = load8(r1 + 1);
    for (int i = 0; i < psz; ++i, i0 += s0) {
        r1 += s1;
        const V8 bot = load8(r1), bots = load8(r1 + 1);
        const V8 d = w00 * top + w01 * tops + w10 * bot + w11 * bots - load8(i0);
        const V8 q = d * d;
        V8 px{}, py{};
        if (Grad) {
            px = d * load8(gx), py = d * load8(gy);
            gx += s0, gy += s0;
        }
        for (int j = 0; j < psz; ++j) {
            p.diff += d[j];
            p.sq += q[j];
            if (Grad) {
                p.gx += px[j];
                p.gy += py[j];
            }
        }
        top = bot, tops = bots;
    }
    return p;
}

// The sums of the patch at i0 against I1 at b: the kernel for the patch size.
template <bool Grad>
inline __attribute__((always_inline)) PatchSums patch_sums(const float *i0, size_t s0, const float *gx,
                                                          const float *gy, const Bilinear &b, size_t s1, int psz) {
    return psz == 8  ? patch8<Grad>(i0, s0, gx, gy, b, s1)
           : psz < 8 ? patch_small<Grad>(i0, s0, gx, gy, b, s1, psz)
                     : patch_any<Grad>(i0, s0, gx, gy, b, s1, psz);
}

// The patch search of one level: a stripe of patch rows per task, two sweeps (down and right,
// then up and left), each trying the patch's own, the initial and the neighbours' flow and
// descending from the best. S: (ws x hs) flows, read from the dense flow (u, v) at the first sweep.
struct Search {
    const Level &l;
    const Tensor &t;
    const cv::Mat1f &u, &v;
    int psz, pstr, inner, ws, hs;
    float *Sx, *Sy;
};

LIDARFLOW_AVX2_CLONES
void search_stripe(const Search &c, int first, int last) {
    const Level &l = c.l;
    const Tensor &t = c.t;
    const int psz = c.psz, psz2 = psz / 2, ws = c.ws;
    float *Sx = c.Sx, *Sy = c.Sy;
    const size_t s0 = l.f0.step1(), s1 = l.f1.step1();
    const bool temporal = !l.init_u.empty();
    const float n = static_cast<float>(psz * psz);
    // Inlined (a lambda would be compiled once, for the baseline ISA, outside the clones).
    auto ssd = [&](int i, int j, float fu, float fv) __attribute__((always_inline)) {
        const Bilinear b = bilinear(l, i, j, fu, fv, psz);
        const float *i0 = l.f0.ptr<float>(i) + j;
        const PatchSums p = patch_sums<false>(i0, s0, nullptr, nullptr, b, s1, psz);
        return p.sq - p.diff * p.diff / n;
    };
    for (int iter = 0; iter < 2; ++iter) {
        const int dir = iter == 0 ? 1 : -1;
        const int start_is = iter == 0 ? first : last - 1, end_is = iter == 0 ? last : first - 1;
        const int start_js = iter == 0 ? 0 : ws - 1, end_js = iter == 0 ? ws : -1;
        int i = start_is * c.pstr;
        for (int is = start_is; dir * is < dir * end_is; is += dir, i += dir * c.pstr) {
            int j = start_js * c.pstr;
            for (int js = start_js; dir * js < dir * end_js; js += dir, j += dir * c.pstr) {
                const size_t at = static_cast<size_t>(is) * ws + js;
                if (iter == 0) {
                    Sx[at] = c.u(i + psz2, j + psz2);
                    Sy[at] = c.v(i + psz2, j + psz2);
                }
                float best = ssd(i, j, Sx[at], Sy[at]);
                if (temporal) {
                    const float cu = l.init_u(i + psz2, j + psz2), cv_ = l.init_v(i + psz2, j + psz2);
                    const float e = ssd(i, j, cu, cv_);
                    if (e < best) best = e, Sx[at] = cu, Sy[at] = cv_;
                }
                if (dir * js > dir * start_js) {
                    const size_t nb = at - dir;
                    const float e = ssd(i, j, Sx[nb], Sy[nb]);
                    if (e < best) best = e, Sx[at] = Sx[nb], Sy[at] = Sy[nb];
                }
                if (dir * is > dir * start_is) {
                    const size_t nb = at - static_cast<size_t>(dir) * ws;
                    const float e = ssd(i, j, Sx[nb], Sy[nb]);
                    if (e < best) best = e, Sx[at] = Sx[nb], Sy[at] = Sy[nb];
                }
                float cu = Sx[at], cv_ = Sy[at];
                float det = t.xx[at] * t.yy[at] - t.xy[at] * t.xy[at];
                if (std::abs(det) < kEps) det = kEps;
                const float h11 = t.yy[at] / det, h12 = -t.xy[at] / det, h22 = t.xx[at] / det;
                const float xs = t.x[at], ys = t.y[at];
                const float *i0 = l.f0.ptr<float>(i) + j, *gx = l.gx.ptr<float>(i) + j, *gy = l.gy.ptr<float>(i) + j;
                float prev = kInf;
                for (int s = 0; s < c.inner; ++s) {
                    const Bilinear b = bilinear(l, i, j, cu, cv_, psz);
                    const PatchSums p = patch_sums<true>(i0, s0, gx, gy, b, s1, psz);
                    const float du = p.gx - p.diff * xs / n, dv = p.gy - p.diff * ys / n;
                    const float sq = p.sq - p.diff * p.diff / n;
                    cu -= h11 * du + h12 * dv;
                    cv_ -= h12 * du + h22 * dv;
                    if (sq >= prev) break;
                    prev = sq;
                }
                // A descent that ran off by more than a patch is not trusted (OpenCV's rule, in double).
                const double eu = cu - Sx[at], ev = cv_ - Sy[at];
                if (std::sqrt(eu * eu + ev * ev) <= psz) Sx[at] = cu, Sy[at] = cv_;
            }
        }
    }
}

void patch_search(const Search &c, int threads) {
    const int stripe = static_cast<int>(std::ceil(c.hs / static_cast<double>(kStripes)));
#pragma omp parallel for schedule(dynamic, 1) num_threads(std::max(1, threads))
    for (int k = 0; k < kStripes; ++k) search_stripe(c, std::min(k * stripe, c.hs), std::min((k + 1) * stripe, c.hs));
}

// For each pixel index along a side of n pixels: the first and last patch (of `count`, every
// `stride` px, `size` px wide) whose flow it averages, as OpenCV's densification steps them
// (pixels past the last patch take the last one).
void covering(int n, int size, int stride, std::vector<int> &first, std::vector<int> &last) {
    first.resize(n), last.resize(n);
    int s = 0, e = -1;
    for (int i = 0; i < n; ++i) {
        if (i % stride == 0 && i + size <= n) ++e;
        if (i - size >= 0 && (i - size) % stride == 0 && s < e) ++s;
        first[i] = s, last[i] = e;
    }
}

// One patch's weighted flow added to the pixels [j0, j1) of row i: the weight is
// 1 / max(1, |I1 at the moved pixel - I0|), as OpenCV's densification computes it. Eight pixels
// at a time where their samples in I1 are consecutive (inside the image), one at a time elsewhere.
inline __attribute__((always_inline)) void add_patch(const Level &l, int i, float su, float sv, int j0, int j1,
                                                     float *acc_u, float *acc_v, float *acc_w) {
    const int w = l.w(), h = l.h();
    const float im = std::min(std::max(static_cast<float>(i) + sv, 0.0f), static_cast<float>(h) - 1.0f - kEps);
    const int il = static_cast<int>(im), iu = il + 1;
    const float fy = im - static_cast<float>(il), gy = static_cast<float>(iu) - im;
    const float *lo = l.f1_at(il, 0), *up = l.f1_at(iu, 0), *i0 = l.f0.ptr<float>(i);
    const float xmax = static_cast<float>(w) - 1.0f - kEps;
    int j = j0;
    const V8 zero = splat8(0.0f), one8 = splat8(1.0f), top = splat8(xmax), u8 = splat8(su), v8 = splat8(sv);
    const V8 fy8 = splat8(fy), gy8 = splat8(gy);
    const I8 iota{0, 1, 2, 3, 4, 5, 6, 7};
    // Eight lanes at a time; past j1 a lane computes but adds nothing (the rows are padded by 8).
    for (; j < j1; j += 8) {
        const I8 active = iota < (j1 - j);
        // std::min(std::max(x, 0), top) and the truncation, lane by lane.
        const V8 x = __builtin_convertvector(iota + j, V8) + u8;
        const V8 lo_x = select(x < zero, zero, x);
        const V8 jm = select(top < lo_x, top, lo_x);
        const I8 jl = __builtin_convertvector(jm, I8);
        if (!all_equal(jl | ~active, (iota + jl[0]) | ~active)) break;  // clamped or rounded: one by one
        const V8 jlf = __builtin_convertvector(jl, V8);
        const V8 fx = jm - jlf, gx = (jlf + one8) - jm;
        const float *b1 = up + jl[0], *b0 = lo + jl[0];
        const V8 diff = fx * fy8 * load8(b1 + 1) + gx * fy8 * load8(b1) + fx * gy8 * load8(b0 + 1) +
                        gx * gy8 * load8(b0) - load8(i0 + j);
        const V8 mag = abs8(diff);
        const V8 coef = one8 / select(one8 < mag, mag, one8);
        const V8 au = load8(acc_u + j), av = load8(acc_v + j), aw = load8(acc_w + j);
        store8(acc_u + j, select(active, au + coef * u8, au));
        store8(acc_v + j, select(active, av + coef * v8, av));
        store8(acc_w + j, select(active, aw + coef, aw));
    }
    for (; j < j1; ++j) {
        const float jm = std::min(std::max(static_cast<float>(j) + su, 0.0f), xmax);
        const int jl = static_cast<int>(jm), ju = jl + 1;
        const float fx = jm - static_cast<float>(jl), gx = static_cast<float>(ju) - jm;
        const float diff = fx * fy * up[ju] + gx * fy * up[jl] + fx * gy * lo[ju] + gx * gy * lo[jl] - i0[j];
        const float coef = 1 / std::max(1.0f, std::abs(diff));
        acc_u[j] += coef * su;
        acc_v[j] += coef * sv;
        acc_w[j] += coef;
    }
}

// A row of patches (su, sv: their flows; [c0, c1): the columns of each) added to pixel row i.
LIDARFLOW_AVX2_CLONES
void add_patch_row(const Level &l, int i, const float *su, const float *sv, int ws, const int *c0, const int *c1,
                   float *acc_u, float *acc_v, float *acc_w) {
    for (int js = 0; js < ws; ++js)
        if (c0[js] < c1[js]) add_patch(l, i, su[js], sv[js], c0[js], c1[js], acc_u, acc_v, acc_w);
}

LIDARFLOW_AVX2_CLONES
void divide_row(const float *au, const float *av, const float *aw, float *u, float *v, int w) {
    for (int j = 0; j < w; ++j) {
        u[j] = au[j] / aw[j];
        v[j] = av[j] / aw[j];
    }
}

// The dense flow of a level from its patches' flows (u, v written whole).
void densify(const Level &l, const std::vector<float> &Sx, const std::vector<float> &Sy, int psz, int pstr, int ws,
             cv::Mat1f &u, cv::Mat1f &v, int threads) {
    const int w = l.w(), h = l.h();
    std::vector<int> is0, is1, js0, js1;
    covering(h, psz, pstr, is0, is1);
    covering(w, psz, pstr, js0, js1);
    // The columns each patch column covers: contiguous, as the pixels' ranges only grow.
    std::vector<int> c0(ws, w), c1(ws, 0);
    for (int j = 0; j < w; ++j)
        for (int js = js0[j]; js <= js1[j]; ++js) c0[js] = std::min(c0[js], j), c1[js] = std::max(c1[js], j + 1);
#pragma omp parallel num_threads(std::max(1, threads))
    {
        std::vector<float> au(w + 8), av(w + 8), aw(w + 8);
#pragma omp for schedule(static)
        for (int i = 0; i < h; ++i) {
            std::fill(au.begin(), au.end(), 0.0f);
            std::fill(av.begin(), av.end(), 0.0f);
            std::fill(aw.begin(), aw.end(), 0.0f);
            // Patch rows outer, columns inner: each pixel sums its patches in OpenCV's order.
            for (int is = is0[i]; is <= is1[i]; ++is) {
                const size_t at = static_cast<size_t>(is) * ws;
                add_patch_row(l, i, Sx.data() + at, Sy.data() + at, ws, c0.data(), c1.data(), au.data(), av.data(),
                              aw.data());
            }
            divide_row(au.data(), av.data(), aw.data(), u.ptr<float>(i), v.ptr<float>(i), w);
        }
    }
}

cv::Mat1f as_float(const cv::Mat &m) {
    cv::Mat1f f;
    m.convertTo(f, CV_32F);
    return f;
}

}  // namespace

void DisOptions::validate() const {
    require(finest_scale >= 0 && finest_scale <= 10, ErrorCode::InvalidArgument,
            "dense inverse search: finest_scale must be in [0, 10]");
    require(patch_size >= 2 && patch_size <= 32, ErrorCode::InvalidArgument,
            "dense inverse search: patch_size must be in [2, 32]");
    require(patch_stride >= 1 && patch_stride <= patch_size, ErrorCode::InvalidArgument,
            "dense inverse search: patch_stride must be in [1, patch_size]");
    require(descent_iterations >= 0 && descent_iterations <= 1000, ErrorCode::InvalidArgument,
            "dense inverse search: descent_iterations must be in [0, 1000]");
    require(threads >= 1 && threads <= 256, ErrorCode::InvalidArgument,
            "dense inverse search: threads must be in [1, 256]");
}

int dis_coarsest_scale(cv::Size size, int patch_size) {
    const int longer = std::max(size.width, size.height), shorter = std::min(size.width, size.height);
    if (patch_size <= 0 || shorter < patch_size) return -1;
    return std::min(static_cast<int>(std::log(longer / (4.0 * patch_size)) / std::log(2.0) + 0.5),
                    static_cast<int>(std::log(static_cast<double>(shorter / patch_size)) / std::log(2.0)));
}

// One level of one image: what a search reads of it as I0 or as I1.
struct DisPyramid::Planes {
    cv::Mat1b image;          // 8-bit (the next level is reduced from it)
    cv::Mat1f padded;         // as float, with a replicated border of kPad
    cv::Mat1s ix, iy;         // Sobel gradients (the patches' structure tensors)
    cv::Mat1f gx, gy;         // the same as float, in planes of `padded`'s size
    cv::Mat1f interior(const cv::Mat1f &m) const { return m(cv::Rect(kPad, kPad, image.cols, image.rows)); }
};

DisPyramid::DisPyramid(const cv::Mat &gray, int finest_scale, int patch_size)
    : size_(gray.size()), finest_(finest_scale), patch_(patch_size) {
    require(!gray.empty() && gray.type() == CV_8UC1, ErrorCode::InvalidArgument,
            "dense inverse search: the image must be non-empty 8-bit gray");
    require(patch_size >= 2 && patch_size <= 32 && finest_scale >= 0 && finest_scale <= 10, ErrorCode::InvalidArgument,
            "dense inverse search: patch_size must be in [2, 32] and finest_scale in [0, 10]");
    coarsest_ = dis_coarsest_scale(gray.size(), patch_size);
    require(coarsest_ >= finest_scale, ErrorCode::InvalidArgument,
            "dense inverse search: a " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                " image is too small for patches of " + std::to_string(patch_size) + " px at level " +
                std::to_string(finest_scale));
    // OpenCV's pyramid: INTER_AREA reductions to 1 / 2^finest, then halvings.
    auto levels = std::make_shared<std::vector<Planes>>(static_cast<size_t>(coarsest_) + 1);
    for (int i = finest_scale; i <= coarsest_; ++i) {
        Planes &l = (*levels)[static_cast<size_t>(i)];
        if (i == finest_scale) {
            const int fraction = 1 << finest_scale;
            cv::resize(gray, l.image, cv::Size(gray.cols / fraction, gray.rows / fraction), 0.0, 0.0, cv::INTER_AREA);
        } else {
            const cv::Mat1b &p = (*levels)[static_cast<size_t>(i) - 1].image;
            cv::resize(p, l.image, cv::Size(p.cols / 2, p.rows / 2), 0.0, 0.0, cv::INTER_AREA);
        }
        cv::Mat ext;
        cv::copyMakeBorder(l.image, ext, kPad, kPad, kPad, kPad, cv::BORDER_REPLICATE);
        l.padded = as_float(ext);
        cv::spatialGradient(l.image, l.ix, l.iy);
        l.gx.create(l.padded.size());
        l.gy.create(l.padded.size());
        l.ix.convertTo(l.interior(l.gx), CV_32F);
        l.iy.convertTo(l.interior(l.gy), CV_32F);
    }
    levels_ = std::move(levels);
}

const DisPyramid::Planes &DisPyramid::level(int i) const { return (*levels_)[static_cast<size_t>(i)]; }

cv::Mat2f dis_flow(const cv::Mat &from, const cv::Mat &to, const DisOptions &o, const cv::Mat2f &initial) {
    o.validate();  // the pyramids check the images; the overload below, sizes and the initial flow
    return dis_flow(DisPyramid(from, o.finest_scale, o.patch_size), DisPyramid(to, o.finest_scale, o.patch_size), o,
                    initial);
}

cv::Mat2f dis_flow(const DisPyramid &from, const DisPyramid &to, const DisOptions &o, const cv::Mat2f &initial) {
    o.validate();
    require(from.size() == to.size(), ErrorCode::SizeMismatch, "dense inverse search: the images differ in size");
    require(from.finest_scale() == o.finest_scale && to.finest_scale() == o.finest_scale &&
                from.patch_size() == o.patch_size && to.patch_size() == o.patch_size,
            ErrorCode::InvalidArgument, "dense inverse search: the pyramids were built for another patch size or level");
    require(initial.empty() || initial.size() == from.size(), ErrorCode::SizeMismatch,
            "dense inverse search: the initial flow must be empty or of the images' size");
    const int psz = o.patch_size, pstr = o.patch_stride, finest = o.finest_scale;
    const int coarsest = from.coarsest_scale();
    cv::Mat flow_uv[2];
    if (!initial.empty()) cv::split(initial, flow_uv);
    std::vector<Level> levels(static_cast<size_t>(coarsest) + 1);
    std::vector<cv::Mat1f> U(levels.size()), V(levels.size());
    for (int i = finest, fraction = 1 << finest; i <= coarsest; ++i, fraction *= 2) {
        const DisPyramid::Planes &a = from.level(i), &b = to.level(i);
        Level &l = levels[static_cast<size_t>(i)];
        l.f0 = a.interior(a.padded);
        l.gx = a.interior(a.gx);
        l.gy = a.interior(a.gy);
        l.f1 = b.padded;
        if (fraction == 1 && !initial.empty()) {  // full size: a resize would copy, x / 1 is x
            l.init_u = flow_uv[0];
            l.init_v = flow_uv[1];
        } else if (!initial.empty()) {
            cv::resize(flow_uv[0], l.init_u, a.image.size());
            l.init_u /= fraction;
            cv::resize(flow_uv[1], l.init_v, a.image.size());
            l.init_v /= fraction;
        }
        U[static_cast<size_t>(i)].create(a.image.size());
        V[static_cast<size_t>(i)].create(a.image.size());
    }
    U[static_cast<size_t>(coarsest)].setTo(0.0f);
    V[static_cast<size_t>(coarsest)].setTo(0.0f);
    std::vector<float> Sx, Sy;
    for (int i = coarsest; i >= finest; --i) {
        const Level &l = levels[static_cast<size_t>(i)];
        const int ws = 1 + (l.w() - psz) / pstr, hs = 1 + (l.h() - psz) / pstr;
        const Tensor t = structure_tensor(l, psz, pstr, ws, hs, from.level(i).ix, from.level(i).iy);
        Sx.assign(static_cast<size_t>(ws) * hs, 0.0f);
        Sy.assign(Sx.size(), 0.0f);
        cv::Mat1f &u = U[static_cast<size_t>(i)], &v = V[static_cast<size_t>(i)];
        const Search search{l, t, u, v, psz, pstr, o.descent_iterations / 2, ws, hs, Sx.data(), Sy.data()};
        patch_search(search, o.threads);
        densify(l, Sx, Sy, psz, pstr, ws, u, v, o.threads);
        if (i > finest) {
            cv::Mat1f &un = U[static_cast<size_t>(i) - 1], &vn = V[static_cast<size_t>(i) - 1];
            cv::resize(u, un, un.size());
            cv::resize(v, vn, vn.size());
            un *= 2;
            vn *= 2;
        }
    }
    cv::Mat uv[] = {U[static_cast<size_t>(finest)], V[static_cast<size_t>(finest)]};
    cv::Mat merged, out;
    cv::merge(uv, 2, merged);
    if (finest == 0) return merged;  // already the images' size and scale
    cv::resize(merged, out, from.size());
    out *= 1 << finest;
    return out;
}

}  // namespace lidarflow::flow
