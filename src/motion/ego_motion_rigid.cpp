// SPDX-License-Identifier: MIT
// The calibrated background model of ego_motion.hpp: the rigid camera motion P' = R P + t,
// fitted to the matches' d1 and flow residuals in pixels.
//
// A match (x, y, d0) is the point P = ray / w with ray = ((x - cx) / fx, (y - cy) / fy, 1) and
// inverse depth w = d0 / (fx B). Scaling P' by w gives n = R ray + t w, so
//   x' = fx n0 / n2 + cx,  y' = fy n1 / n2 + cy,  d1 = d0 / n2,
// which stays finite for d0 -> 0 (points at infinity move by the rotation only).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

#include <omp.h>

#include "core/cpu_dispatch.hpp"
#include "core/random.hpp"
#include "motion/ego_motion.hpp"

namespace lidarflow::motion {
namespace {

using Rng = SplitMix64;

// Points behind (or at) the camera after the motion have no projection; clamping the depth
// ratio keeps a wild hypothesis finite (it is then simply a bad one).
constexpr double kMinDepthRatio = 0.05;

// Matches per block of the refit's sums and of the parallel inlier counts: a fixed size, so
// the sums' order does not depend on the thread count.
constexpr size_t kBlock = 2048;
constexpr size_t kMaxRefit = 16384;  // inliers a refit sums at most
constexpr size_t kProbeBlock = 256;  // probes a hypothesis scores between checks whether it can still win

struct Rigid {
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
};

// R <- exp([dw]x) R (Rodrigues).
void rotate_by(Rigid &m, const double dw[3]) {
    const double th = std::sqrt(dw[0] * dw[0] + dw[1] * dw[1] + dw[2] * dw[2]);
    double E[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (th > 1e-15) {
        const double k[3] = {dw[0] / th, dw[1] / th, dw[2] / th};
        const double s = std::sin(th), c = 1 - std::cos(th);
        const double K[9] = {0, -k[2], k[1], k[2], 0, -k[0], -k[1], k[0], 0};
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                double k2 = 0;
                for (int l = 0; l < 3; ++l) k2 += K[i * 3 + l] * K[l * 3 + j];
                E[i * 3 + j] += s * K[i * 3 + j] + c * k2;
            }
    }
    double out[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double acc = 0;
            for (int l = 0; l < 3; ++l) acc += E[i * 3 + l] * m.R[l * 3 + j];
            out[i * 3 + j] = acc;
        }
    std::copy(out, out + 9, m.R);
}

struct Prediction {
    double m[3];  // R ray
    double n[3];  // R ray + t w
    double w;     // inverse depth d0 / (fx B)
    double xp, yp, d1;
};

Prediction project(const Rigid &m, const StereoCamera &c, double x, double y, double d0) {
    Prediction p;
    const double ray[3] = {(x - c.cx) / c.fx, (y - c.cy) / c.fy, 1.0};
    p.w = d0 / (c.fx * c.baseline);
    for (int i = 0; i < 3; ++i) {
        p.m[i] = m.R[i * 3] * ray[0] + m.R[i * 3 + 1] * ray[1] + m.R[i * 3 + 2] * ray[2];
        p.n[i] = p.m[i] + m.t[i] * p.w;
    }
    const double n2 = std::max(p.n[2], kMinDepthRatio);
    p.xp = c.fx * p.n[0] / n2 + c.cx;
    p.yp = c.fy * p.n[1] / n2 + c.cy;
    p.d1 = d0 / n2;
    return p;
}

struct Data {
    const std::vector<float> &x, &y, &d0, &d1, &u, &v;
    const StereoCamera &cam;
    double d_scale;  // flow_inlier / disparity_inlier: both residuals in "flow pixels"

    // The normal equations' upper triangle (21 entries of J^T J, row-major) and J^T r of the
    // points ids[0 .. n), added into A and b (defined below the struct).
    void accumulate(const Rigid &m, const int *ids, size_t n, double A[21], double b[6]) const;

    // One damped Gauss-Newton step on the points ids[0 .. n); false when the system is singular.
    // The sums go by blocks of a fixed size, added in block order: the same on any thread count.
    bool step(Rigid &m, const int *ids, size_t n, int threads = 1) const {
        const size_t blocks = std::max<size_t>(1, (n + kBlock - 1) / kBlock);
        double one[27] = {};  // RANSAC's minimal samples: no allocation
        std::vector<double> many(blocks > 1 ? blocks * 27 : 0, 0.0);
        double *partial = blocks > 1 ? many.data() : one;
#pragma omp parallel for schedule(static) num_threads(threads) if (blocks > 1 && threads > 1)
        for (size_t k = 0; k < blocks; ++k) {
            const size_t first = k * kBlock;
            accumulate(m, ids + std::min(first, n), std::min(kBlock, n - std::min(first, n)), &partial[k * 27],
                       &partial[k * 27 + 21]);
        }
        double A[36] = {}, b[6] = {};
        for (size_t k = 0; k < blocks; ++k) {
            for (int a = 0, e = 0; a < 6; ++a)
                for (int c = a; c < 6; ++c, ++e) A[a * 6 + c] += partial[k * 27 + e];
            for (int a = 0; a < 6; ++a) b[a] += partial[k * 27 + 21 + a];
        }
        for (int a = 0; a < 6; ++a)
            for (int c = 0; c < a; ++c) A[a * 6 + c] = A[c * 6 + a];
        // Levenberg damping: components the points cannot see (translation when all are far)
        // stay where they are instead of exploding.
        for (int a = 0; a < 6; ++a) A[a * 6 + a] += 1e-6 * A[a * 6 + a] + 1e-3;
        // Cholesky solve of the 6x6 system.
        double L[36] = {};
        for (int i = 0; i < 6; ++i)
            for (int j = 0; j <= i; ++j) {
                double s = A[i * 6 + j];
                for (int k = 0; k < j; ++k) s -= L[i * 6 + k] * L[j * 6 + k];
                if (i == j) {
                    if (!(s > 0)) return false;
                    L[i * 6 + i] = std::sqrt(s);
                } else {
                    L[i * 6 + j] = s / L[j * 6 + j];
                }
            }
        double z[6], d[6];
        for (int i = 0; i < 6; ++i) {
            double s = b[i];
            for (int k = 0; k < i; ++k) s -= L[i * 6 + k] * z[k];
            z[i] = s / L[i * 6 + i];
        }
        for (int i = 5; i >= 0; --i) {
            double s = z[i];
            for (int k = i + 1; k < 6; ++k) s -= L[k * 6 + i] * d[k];
            d[i] = s / L[i * 6 + i];
        }
        for (double e : d)
            if (!std::isfinite(e)) return false;
        rotate_by(m, d);
        for (int k = 0; k < 3; ++k) m.t[k] += d[3 + k];
        return true;
    }
};

// Data::accumulate: every entry of A and b gets the same products added in the same order as a
// loop over the upper triangle would add them, two entries per SSE2 operation (GCC's vector
// extension: the same IEEE operations per element). Row a of the triangle is held as the column
// pairs from the one holding column a on.
using V2 = double __attribute__((vector_size(16)));
// Index of entry (a, c), c >= a, in the row-major upper triangle.
constexpr int triangle_index(int a, int c) { return a * 6 - a * (a - 1) / 2 + (c - a); }
void Data::accumulate(const Rigid &m, const int *ids, size_t n, double A[21], double b[6]) const {
    V2 acc[6][3] = {};  // [row][column pair]; pairs left of the row's first stay unused
    for (int a = 0; a < 6; ++a)
        for (int c = a; c < 6; ++c) acc[a][c / 2][c % 2] = A[triangle_index(a, c)];
    V2 rhs[3] = {{b[0], b[1]}, {b[2], b[3]}, {b[4], b[5]}};
    for (size_t k = 0; k < n; ++k) {
        const int i = ids[k];
        const float xi = x[i], yi = y[i], d0i = d0[i];
        const Prediction p = project(m, cam, xi, yi, d0i);
        if (p.n[2] < kMinDepthRatio) continue;
        const double iz = 1.0 / p.n[2];
        // d(x', y', d1) / dn
        const double gx[3] = {cam.fx * iz, 0, -cam.fx * p.n[0] * iz * iz};
        const double gy[3] = {0, cam.fy * iz, -cam.fy * p.n[1] * iz * iz};
        const double gd[3] = {0, 0, -d_scale * d0i * iz * iz};
        const double r[3] = {p.xp - xi - u[i], p.yp - yi - v[i], d_scale * (p.d1 - d1[i])};
        const double *g[3] = {gx, gy, gd};
        for (int j = 0; j < 3; ++j) {
            // dn / d(dw) = -[m]x, dn / d(dt) = w I
            const double *q = g[j];
            double J[6];
            J[0] = q[2] * p.m[1] - q[1] * p.m[2];
            J[1] = q[0] * p.m[2] - q[2] * p.m[0];
            J[2] = q[1] * p.m[0] - q[0] * p.m[1];
            J[3] = q[0] * p.w, J[4] = q[1] * p.w, J[5] = q[2] * p.w;
            const V2 jp[3] = {{J[0], J[1]}, {J[2], J[3]}, {J[4], J[5]}};
            for (int h = 0; h < 3; ++h) rhs[h] -= jp[h] * r[j];
            for (int a = 0; a < 6; ++a)
                for (int h = a / 2; h < 3; ++h) acc[a][h] += J[a] * jp[h];
        }
    }
    for (int a = 0; a < 6; ++a)
        for (int c = a; c < 6; ++c) A[triangle_index(a, c)] = acc[a][c / 2][c % 2];
    for (int a = 0; a < 6; ++a) b[a] = rhs[a / 2][a % 2];
}

// A fixed set of matches as arrays, so that a model's inliers are counted in a loop the
// compiler vectorises.
struct Probes {
    std::vector<float> x, y, d0, d1, u, v;
    Probes(const Data &data, const std::vector<int> &ids) {
        for (auto *a : {&x, &y, &d0, &d1, &u, &v}) a->resize(ids.size());
        for (size_t k = 0; k < ids.size(); ++k) {
            const int i = ids[k];
            x[k] = data.x[i], y[k] = data.y[i], d0[k] = data.d0[i];
            d1[k] = data.d1[i], u[k] = data.u[i], v[k] = data.v[i];
        }
    }
};

// How many of the probes first .. last - 1 m fits (its d1 residual and the flow's end-point
// residual [px] below the inlier bounds), and fit[k] = 1 for each.
LIDARFLOW_AVX2_CLONES
int count_fits(const Rigid &model, const StereoCamera &camera, const Probes &p, size_t first, size_t last,
               double disparity_inlier, double flow_inlier, uint8_t *__restrict fit) {
    // Copies, not loads through references: the byte stores below could alias them.
    const Rigid m = model;
    const StereoCamera c = camera;
    const float *__restrict x = p.x.data(), *__restrict y = p.y.data(), *__restrict d0 = p.d0.data();
    const float *__restrict d1 = p.d1.data(), *__restrict u = p.u.data(), *__restrict v = p.v.data();
    int count = 0;
    for (size_t k = first; k < last; ++k) {
        const Prediction q = project(m, c, x[k], y[k], d0[k]);
        const double ex = q.xp - x[k] - u[k], ey = q.yp - y[k] - v[k];
        const int in = (std::fabs(q.d1 - d1[k]) < disparity_inlier) & (std::sqrt(ex * ex + ey * ey) < flow_inlier);
        count += in;
        fit[k] = static_cast<uint8_t>(in);
    }
    return count;
}

}  // namespace

bool detail::predict_rigid(const EgoMotion &em, float x, float y, float d0, float &d1, float &u, float &v) {
    Rigid m;
    std::copy(em.R, em.R + 9, m.R);
    std::copy(em.t, em.t + 3, m.t);
    const Prediction p = project(m, em.camera, x, y, std::max(0.0f, d0));
    d1 = static_cast<float>(p.d1);
    u = static_cast<float>(p.xp - x);
    v = static_cast<float>(p.yp - y);
    return p.n[2] >= kMinDepthRatio;
}

namespace {

// predict_rigid for n points: project()'s operations in its order per point (the same doubles),
// on plain arrays so that the loop vectorises (its divisions dominate one point at a time).
LIDARFLOW_AVX2_CLONES
void predict_rigid_many_cloned(const EgoMotion &em, const float *x, const float *y, const float *d0, int n, float *d1,
                               float *u, float *v) {
    const double *R = em.R, *t = em.t;
    const double r00 = R[0], r01 = R[1], r02 = R[2], r10 = R[3], r11 = R[4], r12 = R[5], r20 = R[6], r21 = R[7],
                 r22 = R[8], t0 = t[0], t1 = t[1], t2 = t[2];
    const StereoCamera &c = em.camera;
    const double cx = c.cx, cy = c.cy, fx = c.fx, fy = c.fy, fxb = c.fx * c.baseline;
    for (int i = 0; i < n; ++i) {
        const double px = x[i], py = y[i], dd = std::max(0.0f, d0[i]);
        const double ray0 = (px - cx) / fx, ray1 = (py - cy) / fy, ray2 = 1.0;
        const double w = dd / fxb;
        const double n0 = r00 * ray0 + r01 * ray1 + r02 * ray2 + t0 * w;
        const double n1 = r10 * ray0 + r11 * ray1 + r12 * ray2 + t1 * w;
        const double nz = r20 * ray0 + r21 * ray1 + r22 * ray2 + t2 * w;
        const double n2 = std::max(nz, kMinDepthRatio);
        d1[i] = static_cast<float>(dd / n2);
        u[i] = static_cast<float>(fx * n0 / n2 + cx - px);
        v[i] = static_cast<float>(fy * n1 / n2 + cy - py);
    }
}

}  // namespace

// Other translation units' entry to the cloned kernel (core/cpu_dispatch.hpp: clones stay
// internal).
void detail::predict_rigid_many(const EgoMotion &em, const float *x, const float *y, const float *d0, int n, float *d1,
                                float *u, float *v) {
    predict_rigid_many_cloned(em, x, y, d0, n, d1, u, v);
}

EgoMotion EgoMotion::inverse() const {
    EgoMotion inv;
    if (!valid || !calibrated) return inv;
    inv = *this;
    for (int i = 0; i < 3; ++i) {
        inv.t[i] = 0;
        for (int j = 0; j < 3; ++j) {
            inv.R[i * 3 + j] = R[j * 3 + i];
            inv.t[i] -= R[j * 3 + i] * t[j];
        }
    }
    return inv;
}

EgoMotion fit_rigid_ego_motion(const std::vector<float> &x, const std::vector<float> &y, const std::vector<float> &d0,
                               const std::vector<float> &d1, const std::vector<float> &u,
                               const std::vector<float> &v, const EgoMotionOptions &o,
                               const StereoCamera &camera) {
    EgoMotion em;
    for (double c : {camera.fx, camera.fy, camera.cx, camera.cy, camera.baseline})
        if (!std::isfinite(c)) return em;
    if (!camera.valid()) return em;
    const size_t len = x.size();
    if (y.size() != len || d0.size() != len || d1.size() != len || u.size() != len || v.size() != len) return em;
    const Data data{x, y, d0, d1, u, v, camera, o.flow_inlier / o.disparity_inlier};
    std::vector<int> ids;
    for (int i = 0; i < static_cast<int>(len); ++i)
        if (d0[i] > 0.5f && d1[i] > 0.5f) ids.push_back(i);
    const int n = static_cast<int>(ids.size());
    em.candidates = n;
    if (n < std::max(o.min_inliers, 8)) return em;
    std::vector<int> probe;
    const int stride = std::max(1, n / 3000);
    for (int k = 0; k < n; k += stride) probe.push_back(ids[k]);
    Rng rng(0x516ull ^ (static_cast<uint64_t>(o.seed) << 17));

    const int threads = std::max(1, o.threads);
    // Inliers of m among all matches; their ids, in order, into *out when given. The per-point
    // tests run in parallel, the count is an integer: the same on any thread count.
    const Probes all(data, ids);
    std::vector<uint8_t> is_inlier(static_cast<size_t>(n));
    auto inliers_of = [&](const Rigid &m, std::vector<int> *out) {
        const int chunks = static_cast<int>((static_cast<size_t>(n) + kBlock - 1) / kBlock);
        int inliers = 0;
#pragma omp parallel for schedule(static) reduction(+ : inliers) num_threads(threads)
        for (int b = 0; b < chunks; ++b)
            inliers += count_fits(m, camera, all, b * kBlock, std::min(static_cast<size_t>(n), (b + 1) * kBlock),
                                  o.disparity_inlier, o.flow_inlier, is_inlier.data());
        if (out) {
            out->clear();
            for (int k = 0; k < n; ++k)
                if (is_inlier[k]) out->push_back(ids[k]);
        }
        return inliers;
    };
    // Every hypothesis' sample is drawn first, in the order one loop over them would draw it;
    // the hypotheses are then solved and scored in parallel, and the first of the best in draw
    // order wins, as in that loop.
    const int hypotheses = o.hypotheses;
    std::vector<int> samples(3 * static_cast<size_t>(std::max(hypotheses, 0)));
    for (int h = 0; h < hypotheses; ++h) {
        int *sample = &samples[3 * static_cast<size_t>(h)];
        for (int k = 0; k < 3; ++k) {
            int tries = 0;
            do {
                sample[k] = probe[rng.below(static_cast<int>(probe.size()))];
            } while (std::find(sample, sample + k, sample[k]) != sample + k && ++tries < 8);
        }
    }
    std::vector<Rigid> models(samples.size() / 3);
    std::vector<int> counts(samples.size() / 3, -1);
    const Probes probes(data, probe);
    std::vector<std::vector<uint8_t>> scratch(threads, std::vector<uint8_t>(probe.size()));
    // The best count so far of any finished hypothesis: one whose count cannot reach it even if
    // every probe left fits cannot win (the winner's count is at least as high), so its scoring
    // stops there. Which ones stop depends on the threads' timing; the winner does not.
    std::atomic<int> best_known{-1};
    const size_t probe_count = probe.size();
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
    for (int h = 0; h < hypotheses; ++h) {
        Rigid m;
        bool ok = true;
        for (int it = 0; it < 6 && ok; ++it) ok = data.step(m, &samples[3 * static_cast<size_t>(h)], 3);
        if (!ok) continue;
        models[h] = m;
        uint8_t *fit = scratch[static_cast<size_t>(omp_get_thread_num())].data();
        int count = 0;
        for (size_t first = 0; first < probe_count; first += kProbeBlock) {
            const size_t last = std::min(probe_count, first + kProbeBlock);
            count += count_fits(m, camera, probes, first, last, o.disparity_inlier, o.flow_inlier, fit);
            if (count + static_cast<int>(probe_count - last) < best_known.load(std::memory_order_relaxed)) {
                count = -1;  // cannot win
                break;
            }
        }
        counts[h] = count;
        for (int known = best_known.load(std::memory_order_relaxed);
             count > known && !best_known.compare_exchange_weak(known, count, std::memory_order_relaxed);) {
        }
    }
    Rigid best;
    int best_count = -1;
    for (int h = 0; h < hypotheses; ++h)
        if (counts[h] > best_count) best_count = counts[h], best = models[h];
    if (best_count < 4) return em;
    // Refit on the inliers of all matches; the inlier set is re-selected each round.
    std::vector<int> in;
    for (int round = 0; round < 3; ++round) {
        if (inliers_of(best, &in) < 4) break;
        // The refit's sums over at most kMaxRefit inliers, every k-th: beyond that a dense
        // scan's points add time, not precision, to six parameters.
        if (in.size() > kMaxRefit) {
            const size_t stride = (in.size() + kMaxRefit - 1) / kMaxRefit;
            size_t kept = 0;
            for (size_t k = 0; k < in.size(); k += stride) in[kept++] = in[k];
            in.resize(kept);
        }
        Rigid m = best;
        bool ok = true;
        for (int it = 0; it < 3 && ok; ++it) ok = data.step(m, in.data(), in.size(), threads);
        if (!ok) break;
        best = m;
    }
    em.calibrated = true;
    em.camera = camera;
    std::copy(best.R, best.R + 9, em.R);
    std::copy(best.t, best.t + 3, em.t);
    em.inliers = inliers_of(best, nullptr);
    em.valid = em.inliers >= std::max(o.min_inliers, static_cast<int>(std::ceil(o.min_inlier_share * n)));
    return em;
}

}  // namespace lidarflow::motion
