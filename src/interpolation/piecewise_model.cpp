// SPDX-License-Identifier: MIT
#include "interpolation/piecewise_model.hpp"

#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "core/cpu_dispatch.hpp"

namespace lidarflow::interpolation {

bool plane_from_3(const float x[3], const float y[3], const float z[3], Plane &out) {
    const double x1 = x[1] - x[0], y1 = y[1] - y[0], x2 = x[2] - x[0], y2 = y[2] - y[0];
    const double det = x1 * y2 - x2 * y1;  // twice the triangle's signed area
    const double l01 = x1 * x1 + y1 * y1, l02 = x2 * x2 + y2 * y2;
    const double l12 = (x2 - x1) * (x2 - x1) + (y2 - y1) * (y2 - y1);
    const double longest = std::max({l01, l02, l12});
    // Slivers extrapolate wildly across the superpixel: demand a height of >= 5% of the
    // longest side and at least ~1.5 px^2 of area.
    if (std::fabs(det) < std::max(3.0, 0.05 * longest)) return false;
    const double z1 = z[1] - z[0], z2 = z[2] - z[0];
    const double a = (z1 * y2 - z2 * y1) / det;
    const double b = (x1 * z2 - x2 * z1) / det;
    out.a = static_cast<float>(a);
    out.b = static_cast<float>(b);
    out.c = static_cast<float>(z[0] - a * x[0] - b * y[0]);
    return true;
}

bool PlaneLsq::solve(int dims, Model &out) const {
    if (s1_ <= 0) return false;
    // Centre on the weighted mean: the 2x2 slope system then decouples from the offset.
    const double mx = sx_ / s1_, my = sy_ / s1_;
    const double cxx = sxx_ / s1_ - mx * mx, cxy = sxy_ / s1_ - mx * my, cyy = syy_ / s1_ - my * my;
    const double det = cxx * cyy - cxy * cxy;
    const double tr = cxx + cyy;
    // Points spread along a line (or a single point) leave one slope undetermined.
    if (!(tr > 0.25) || det < 0.01 * tr * tr) return false;
    for (int k = 0; k < dims; ++k) {
        const double mz = sz_[k] / s1_;
        const double cxz = sxz_[k] / s1_ - mx * mz, cyz = syz_[k] / s1_ - my * mz;
        const double a = (cxz * cyy - cyz * cxy) / det;
        const double b = (cyz * cxx - cxz * cxy) / det;
        const double c0 = mz - a * mx - b * my;  // value at the origin (ox, oy)
        out.p[k].a = static_cast<float>(a);
        out.p[k].b = static_cast<float>(b);
        out.p[k].c = static_cast<float>(c0 - a * ox_ - b * oy_);
    }
    return true;
}

namespace {

void lanes_portable(const Model &m, bool two, const float *x, const float *y, const float *z0, const float *z1,
                    const float *w, int n, float tau, float acc[8]) {
    for (int j = 0; j < n; ++j) {
        const float r0 = m.p[0].at(x[j], y[j]) - z0[j];
        float r;
        if (two) {
            const float r1 = m.p[1].at(x[j], y[j]) - z1[j];
            r = std::sqrt(r0 * r0 + r1 * r1);
        } else {
            r = std::fabs(r0);
        }
        acc[j % 8] += w[j] * (tau < r ? tau : r);
    }
}

#if defined(__SSE2__)
void lanes_sse2(const Model &m, bool two, const float *x, const float *y, const float *z0, const float *z1,
                const float *w, int n, float tau, float acc[8]) {
    const Plane p0 = m.p[0], p1 = m.p[1];
    const __m128 a0 = _mm_set1_ps(p0.a), b0 = _mm_set1_ps(p0.b), c0 = _mm_set1_ps(p0.c);
    const __m128 a1 = _mm_set1_ps(p1.a), b1 = _mm_set1_ps(p1.b), c1 = _mm_set1_ps(p1.c);
    const __m128 t = _mm_set1_ps(tau), sign = _mm_set1_ps(-0.0f);
    __m128 s[2] = {_mm_loadu_ps(acc), _mm_loadu_ps(acc + 4)};
    for (int i = 0; i < n; i += 8)
        for (int h = 0; h < 2; ++h) {
            const int j = i + 4 * h;
            const __m128 xs = _mm_loadu_ps(x + j), ys = _mm_loadu_ps(y + j);
            const __m128 r0 =
                _mm_sub_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(a0, xs), _mm_mul_ps(b0, ys)), c0), _mm_loadu_ps(z0 + j));
            __m128 r;
            if (two) {
                const __m128 r1 = _mm_sub_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(a1, xs), _mm_mul_ps(b1, ys)), c1),
                                             _mm_loadu_ps(z1 + j));
                r = _mm_sqrt_ps(_mm_add_ps(_mm_mul_ps(r0, r0), _mm_mul_ps(r1, r1)));
            } else {
                r = _mm_andnot_ps(sign, r0);
            }
            // minps(t, r) is t < r ? t : r, NaN included.
            s[h] = _mm_add_ps(s[h], _mm_mul_ps(_mm_loadu_ps(w + j), _mm_min_ps(t, r)));
        }
    _mm_storeu_ps(acc, s[0]);
    _mm_storeu_ps(acc + 4, s[1]);
}
#endif

#if defined(__x86_64__) && defined(__SSE2__)
// The same per lane as lanes_sse2, eight lanes in one register (AVX2 without FMA).
__attribute__((target("avx2"))) void lanes_avx2(const Model &m, bool two, const float *x, const float *y,
                                                const float *z0, const float *z1, const float *w, int n,
                                                float tau, float acc[8]) {
    const Plane p0 = m.p[0], p1 = m.p[1];
    const __m256 a0 = _mm256_set1_ps(p0.a), b0 = _mm256_set1_ps(p0.b), c0 = _mm256_set1_ps(p0.c);
    const __m256 a1 = _mm256_set1_ps(p1.a), b1 = _mm256_set1_ps(p1.b), c1 = _mm256_set1_ps(p1.c);
    const __m256 t = _mm256_set1_ps(tau), sign = _mm256_set1_ps(-0.0f);
    __m256 s = _mm256_loadu_ps(acc);
    for (int j = 0; j < n; j += 8) {
        const __m256 xs = _mm256_loadu_ps(x + j), ys = _mm256_loadu_ps(y + j);
        const __m256 r0 = _mm256_sub_ps(
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a0, xs), _mm256_mul_ps(b0, ys)), c0), _mm256_loadu_ps(z0 + j));
        __m256 r;
        if (two) {
            const __m256 r1 = _mm256_sub_ps(
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a1, xs), _mm256_mul_ps(b1, ys)), c1), _mm256_loadu_ps(z1 + j));
            r = _mm256_sqrt_ps(_mm256_add_ps(_mm256_mul_ps(r0, r0), _mm256_mul_ps(r1, r1)));
        } else {
            r = _mm256_andnot_ps(sign, r0);
        }
        s = _mm256_add_ps(s, _mm256_mul_ps(_mm256_loadu_ps(w + j), _mm256_min_ps(t, r)));
    }
    _mm256_storeu_ps(acc, s);
}

#endif

}  // namespace

bool lane_isa_available(LaneIsa isa) {
    switch (isa) {
    case LaneIsa::Best:
    case LaneIsa::Portable: return true;
#if defined(__SSE2__)
    case LaneIsa::Sse2: return true;
#endif
#if defined(__x86_64__) && defined(__SSE2__)
    case LaneIsa::Avx2: return cpu_has_avx2();
#endif
    default: return false;
    }
}

void robust_lanes(const Model &m, int dims, const float *x, const float *y, const float *z0, const float *z1,
                  const float *w, int n, float tau, float acc[8], LaneIsa isa) {
    const bool two = dims == 2;
#if defined(__x86_64__) && defined(__SSE2__)
    if ((isa == LaneIsa::Best || isa == LaneIsa::Avx2) && cpu_has_avx2())
        return lanes_avx2(m, two, x, y, z0, z1, w, n, tau, acc);
#endif
#if defined(__SSE2__)
    if (isa == LaneIsa::Best || isa == LaneIsa::Sse2) return lanes_sse2(m, two, x, y, z0, z1, w, n, tau, acc);
#endif
    lanes_portable(m, two, x, y, z0, z1, w, n, tau, acc);
}

}  // namespace lidarflow::interpolation
