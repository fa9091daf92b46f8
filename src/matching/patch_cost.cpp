// SPDX-License-Identifier: MIT
#include "matching/patch_cost.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <immintrin.h>

#include "core/error.hpp"

namespace lidarflow::matching {

PatchShape::PatchShape(int r, int s) : radius(r), step(s) {
    require(r >= 0 && r <= 16, ErrorCode::InvalidArgument, "PatchShape: radius must be in [0, 16]");
    require(s >= 1, ErrorCode::InvalidArgument, "PatchShape: step must be >= 1");
    // Samples symmetric about the centre: offsets that are multiples of step within the radius.
    const int k = r / s;
    for (int j = -k; j <= k; ++j)
        for (int i = -k; i <= k; ++i) {
            dx.push_back(i * s);
            dy.push_back(j * s);
        }
}

namespace {

inline uint32_t hsum_epi32(__m128i v) {
    v = _mm_add_epi32(v, _mm_shuffle_epi32(v, _MM_SHUFFLE(1, 0, 3, 2)));
    v = _mm_add_epi32(v, _mm_shuffle_epi32(v, _MM_SHUFFLE(2, 3, 0, 1)));
    return static_cast<uint32_t>(_mm_cvtsi128_si32(v));
}

__attribute__((always_inline)) inline uint32_t l2sq(const uint8_t *a, const uint8_t *b, int dim) {
    const __m128i zero = _mm_setzero_si128();
    __m128i acc = zero;
    for (int i = 0; i < dim; i += 16) {
        const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i *>(a + i));
        const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i *>(b + i));
        const __m128i d = _mm_or_si128(_mm_subs_epu8(va, vb), _mm_subs_epu8(vb, va));
        const __m128i lo = _mm_unpacklo_epi8(d, zero);
        const __m128i hi = _mm_unpackhi_epi8(d, zero);
        acc = _mm_add_epi32(acc, _mm_madd_epi16(lo, lo));
        acc = _mm_add_epi32(acc, _mm_madd_epi16(hi, hi));
    }
    return hsum_epi32(acc);
}

__attribute__((always_inline)) inline uint32_t l1(const uint8_t *a, const uint8_t *b, int dim) {
    __m128i acc = _mm_setzero_si128();
    for (int i = 0; i < dim; i += 16) {
        const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i *>(a + i));
        const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i *>(b + i));
        acc = _mm_add_epi64(acc, _mm_sad_epu8(va, vb));
    }
    return static_cast<uint32_t>(_mm_cvtsi128_si32(acc) + _mm_cvtsi128_si32(_mm_srli_si128(acc, 8)));
}

}  // namespace

float descriptor_distance(const uint8_t *a, const uint8_t *b, int dim, DescriptorNorm norm) {
    if (norm == DescriptorNorm::L1) return static_cast<float>(l1(a, b, dim));
    return std::sqrt(static_cast<float>(l2sq(a, b, dim)));
}

namespace {

// The patch loop, generic over the per-sample distance kernel.
template <uint32_t (*L2SQ)(const uint8_t *, const uint8_t *, int),
          uint32_t (*L1)(const uint8_t *, const uint8_t *, int)>
inline float patch_cost_impl(const features::DescriptorImage &a, const features::DescriptorImage &b, int ax,
                             int ay, int bx, int by, const PatchShape &shape, DescriptorNorm norm,
                             float penalty, float bound) {
    const int n = shape.samples();
    if (ax < 0 || ay < 0 || ax >= a.width || ay >= a.height || bx < 0 || by < 0 || bx >= b.width ||
        by >= b.height)
        return penalty * static_cast<float>(n);
    const int dim = a.dim;
    // Eq. 2's per-sample term: the descriptor distance of one patch sample.
    const auto sample = [dim, norm](const uint8_t *da, const uint8_t *db) {
        return norm == DescriptorNorm::L1 ? static_cast<float>(L1(da, db, dim))
                                          : std::sqrt(static_cast<float>(L2SQ(da, db, dim)));
    };
    float sum = 0.0f;
    const int r = shape.radius;
    if (ax >= r && ay >= r && bx >= r && by >= r && ax + r < a.width && ay + r < a.height &&
        bx + r < b.width && by + r < b.height) {
        // Fast path: the whole patch is inside both images, no clamping.
        const uint8_t *ca = a.at(ax, ay), *cb = b.at(bx, by);
        const ptrdiff_t rowa = static_cast<ptrdiff_t>(a.width) * dim, rowb = static_cast<ptrdiff_t>(b.width) * dim;
        // The samples lie in rows far apart (cache and TLB misses): request all their lines
        // first so that the misses overlap instead of being paid one after another.
        for (int k = 0; k < n; ++k) {
            const uint8_t *da = ca + shape.dy[k] * rowa + shape.dx[k] * dim;
            const uint8_t *db = cb + shape.dy[k] * rowb + shape.dx[k] * dim;
            for (int off = 0; off < dim; off += 64) {
                _mm_prefetch(reinterpret_cast<const char *>(da + off), _MM_HINT_T0);
                _mm_prefetch(reinterpret_cast<const char *>(db + off), _MM_HINT_T0);
            }
        }
        for (int k = 0; k < n; ++k) {
            sum += sample(ca + shape.dy[k] * rowa + shape.dx[k] * dim, cb + shape.dy[k] * rowb + shape.dx[k] * dim);
            if (sum > bound) return sum;
        }
        return sum;
    }
    for (int k = 0; k < n; ++k) {
        const int pax = std::clamp(ax + shape.dx[k], 0, a.width - 1);
        const int pay = std::clamp(ay + shape.dy[k], 0, a.height - 1);
        const int pbx = std::clamp(bx + shape.dx[k], 0, b.width - 1);
        const int pby = std::clamp(by + shape.dy[k], 0, b.height - 1);
        sum += sample(a.at(pax, pay), b.at(pbx, pby));
        if (sum > bound) return sum;
    }
    return sum;
}

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#define LIDARFLOW_HAVE_AVX2_PATH 1
// AVX2 kernels (dim is a multiple of 16; 32-byte steps plus one 16-byte tail when needed),
// compiled for AVX2 only in these functions and chosen at run time.
__attribute__((target("avx2"))) inline uint32_t l2sq_avx2(const uint8_t *a, const uint8_t *b, int dim) {
    const __m256i zero = _mm256_setzero_si256();
    __m256i acc = zero;
    int i = 0;
    for (; i + 32 <= dim; i += 32) {
        const __m256i va = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(a + i));
        const __m256i vb = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(b + i));
        const __m256i d = _mm256_or_si256(_mm256_subs_epu8(va, vb), _mm256_subs_epu8(vb, va));
        const __m256i lo = _mm256_unpacklo_epi8(d, zero);
        const __m256i hi = _mm256_unpackhi_epi8(d, zero);
        acc = _mm256_add_epi32(acc, _mm256_madd_epi16(lo, lo));
        acc = _mm256_add_epi32(acc, _mm256_madd_epi16(hi, hi));
    }
    __m128i s = _mm_add_epi32(_mm256_castsi256_si128(acc), _mm256_extracti128_si256(acc, 1));
    uint32_t total = hsum_epi32(s);
    if (i < dim) total += l2sq(a + i, b + i, dim - i);
    return total;
}

__attribute__((target("avx2"))) inline uint32_t l1_avx2(const uint8_t *a, const uint8_t *b, int dim) {
    __m256i acc = _mm256_setzero_si256();
    int i = 0;
    for (; i + 32 <= dim; i += 32) {
        const __m256i va = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(a + i));
        const __m256i vb = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(b + i));
        acc = _mm256_add_epi64(acc, _mm256_sad_epu8(va, vb));
    }
    const __m128i s = _mm_add_epi64(_mm256_castsi256_si128(acc), _mm256_extracti128_si256(acc, 1));
    uint32_t total = static_cast<uint32_t>(_mm_cvtsi128_si32(s) + _mm_cvtsi128_si32(_mm_srli_si128(s, 8)));
    if (i < dim) total += l1(a + i, b + i, dim - i);
    return total;
}

// flatten: the generic patch loop and the AVX2 kernels are inlined into one AVX2 function.
__attribute__((target("avx2"), flatten)) float patch_cost_avx2(const features::DescriptorImage &a,
                                                      const features::DescriptorImage &b, int ax, int ay,
                                                      int bx, int by, const PatchShape &shape,
                                                      DescriptorNorm norm, float penalty, float bound) {
    return patch_cost_impl<l2sq_avx2, l1_avx2>(a, b, ax, ay, bx, by, shape, norm, penalty, bound);
}

const bool kUseAvx2 = __builtin_cpu_supports("avx2");
#endif

}  // namespace

namespace {
float patch_cost_sse2(const features::DescriptorImage &a, const features::DescriptorImage &b, int ax, int ay,
                      int bx, int by, const PatchShape &shape, DescriptorNorm norm, float penalty, float bound) {
    return patch_cost_impl<l2sq, l1>(a, b, ax, ay, bx, by, shape, norm, penalty, bound);
}
}  // namespace

PatchCostFn patch_cost_kernel() {
#ifdef LIDARFLOW_HAVE_AVX2_PATH
    if (kUseAvx2) return patch_cost_avx2;
#endif
    return patch_cost_sse2;
}

float patch_cost(const features::DescriptorImage &a, const features::DescriptorImage &b, int ax,
                 int ay, int bx, int by, const PatchShape &shape, DescriptorNorm norm,
                 float penalty, float bound) {
    return patch_cost_kernel()(a, b, ax, ay, bx, by, shape, norm, penalty, bound);
}

}  // namespace lidarflow::matching
