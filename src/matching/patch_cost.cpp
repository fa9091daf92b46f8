// SPDX-License-Identifier: MIT
#include "matching/patch_cost.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <immintrin.h>

#include "core/cpu_dispatch.hpp"
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

// Packed 4-bit descriptors (features::DenseSiftOptions::bits): `bytes` bytes of two codes
// each, compared through their decoded values.
__attribute__((always_inline)) inline uint32_t l2sq_packed(const uint8_t *a, const uint8_t *b, int bytes,
                                                           const uint8_t *ta, const uint8_t *tb) {
    uint32_t acc = 0;
    for (int i = 0; i < bytes; ++i) {
        const int dl = ta[a[i] & 15] - tb[b[i] & 15], dh = ta[a[i] >> 4] - tb[b[i] >> 4];
        acc += static_cast<uint32_t>(dl * dl + dh * dh);
    }
    return acc;
}

__attribute__((always_inline)) inline uint32_t l1_packed(const uint8_t *a, const uint8_t *b, int bytes,
                                                         const uint8_t *ta, const uint8_t *tb) {
    uint32_t acc = 0;
    for (int i = 0; i < bytes; ++i)
        acc += static_cast<uint32_t>(std::abs(ta[a[i] & 15] - tb[b[i] & 15]) + std::abs(ta[a[i] >> 4] - tb[b[i] >> 4]));
    return acc;
}

}  // namespace

float descriptor_distance(const uint8_t *a, const uint8_t *b, int dim, DescriptorNorm norm) {
    if (norm == DescriptorNorm::L1) return static_cast<float>(l1(a, b, dim));
    return std::sqrt(static_cast<float>(l2sq(a, b, dim)));
}

namespace {

// One descriptor image as the patch loop reads it, its fields read once per patch cost.
struct View {
    const uint8_t *data, *contrast;
    ptrdiff_t width;
    int stride;  // bytes per descriptor
    explicit View(const features::DescriptorImage &d)
        : data(d.bytes()), contrast(d.contrast_bytes()), width(d.width), stride(d.stride()) {}
    const uint8_t *at(ptrdiff_t i) const { return data + i * stride; }  // i = y * width + x
};

// The patch loop, generic over the per-sample distance: K::sample(a, pixel of a, b, pixel of b,
// norm) with pixels as indices y * width + x.
template <class K>
inline float patch_cost_impl(const features::DescriptorImage &da, const features::DescriptorImage &db, int ax,
                             int ay, int bx, int by, const PatchShape &shape, DescriptorNorm norm,
                             float penalty, float bound) {
    const int n = shape.samples();
    if (ax < 0 || ay < 0 || ax >= da.width || ay >= da.height || bx < 0 || by < 0 || bx >= db.width ||
        by >= db.height)
        return penalty * static_cast<float>(n);
    const View a(da), b(db);
    float sum = 0.0f;
    const int r = shape.radius;
    if (ax >= r && ay >= r && bx >= r && by >= r && ax + r < da.width && ay + r < da.height &&
        bx + r < db.width && by + r < db.height) {
        // Fast path: the whole patch is inside both images, no clamping.
        const ptrdiff_t ca = ay * a.width + ax, cb = by * b.width + bx;
        // The samples lie in rows far apart (cache and TLB misses): request all their lines
        // first so that the misses overlap instead of being paid one after another.
        for (int k = 0; k < n; ++k)
            K::prefetch(a, ca + shape.dy[k] * a.width + shape.dx[k], b, cb + shape.dy[k] * b.width + shape.dx[k]);
        if (K::whole_patch(a, ca, b, cb, shape, norm, bound, sum)) return sum;
        for (int k = 0; k < n; ++k) {
            sum += K::sample(a, ca + shape.dy[k] * a.width + shape.dx[k], b, cb + shape.dy[k] * b.width + shape.dx[k],
                             norm);
            if (sum > bound) return sum;
        }
        return sum;
    }
    for (int k = 0; k < n; ++k) {
        const int pax = std::clamp(ax + shape.dx[k], 0, da.width - 1);
        const int pay = std::clamp(ay + shape.dy[k], 0, da.height - 1);
        const int pbx = std::clamp(bx + shape.dx[k], 0, db.width - 1);
        const int pby = std::clamp(by + shape.dy[k], 0, db.height - 1);
        sum += K::sample(a, pay * a.width + pax, b, pby * b.width + pbx, norm);
        if (sum > bound) return sum;
    }
    return sum;
}

// Both samples' descriptor lines, interleaved a / b / a / b: requesting all of a's lines
// first made stage 1 ~3 % slower (user CPU of bench_matching, four alternations).
inline void prefetch_pair(const uint8_t *pa, const uint8_t *pb, int bytes) {
    for (int off = 0; off < bytes; off += 64) {
        _mm_prefetch(reinterpret_cast<const char *>(pa + off), _MM_HINT_T0);
        _mm_prefetch(reinterpret_cast<const char *>(pb + off), _MM_HINT_T0);
    }
}

// K::whole_patch(a, centre of a, b, centre of b, shape, norm, bound, cost): a kernel for the
// whole in-image patch where the layout and norm have one; false (the per-sample loop) here.
struct NoWholePatch {
    static bool whole_patch(const View &, ptrdiff_t, const View &, ptrdiff_t, const PatchShape &, DescriptorNorm,
                            float, float &) {
        return false;
    }
};

// Eq. 2's per-sample term on 8-bit descriptors.
template <uint32_t (*L2SQ)(const uint8_t *, const uint8_t *, int),
          uint32_t (*L1)(const uint8_t *, const uint8_t *, int)>
struct ByteKernel : NoWholePatch {
    static void prefetch(const View &a, ptrdiff_t ia, const View &b, ptrdiff_t ib) {
        prefetch_pair(a.at(ia), b.at(ib), a.stride);
    }
    static float sample(const View &a, ptrdiff_t ia, const View &b, ptrdiff_t ib, DescriptorNorm norm) {
        return norm == DescriptorNorm::L1 ? static_cast<float>(L1(a.at(ia), b.at(ib), a.stride))
                                          : std::sqrt(static_cast<float>(L2SQ(a.at(ia), b.at(ib), a.stride)));
    }
};

// The same on packed 4-bit descriptors: each descriptor's codes are decoded through the table
// of its own contrast (features::packed_levels).
template <uint32_t (*L2SQ)(const uint8_t *, const uint8_t *, int, const uint8_t *, const uint8_t *),
          uint32_t (*L1)(const uint8_t *, const uint8_t *, int, const uint8_t *, const uint8_t *)>
struct PackedKernel : NoWholePatch {
    static void prefetch(const View &a, ptrdiff_t ia, const View &b, ptrdiff_t ib) {
        prefetch_pair(a.at(ia), b.at(ib), a.stride);
        _mm_prefetch(reinterpret_cast<const char *>(a.contrast + ia), _MM_HINT_T0);
        _mm_prefetch(reinterpret_cast<const char *>(b.contrast + ib), _MM_HINT_T0);
    }
    static float sample(const View &a, ptrdiff_t ia, const View &b, ptrdiff_t ib, DescriptorNorm norm) {
        const uint8_t *ta = features::packed_levels(a.contrast[ia]), *tb = features::packed_levels(b.contrast[ib]);
        return norm == DescriptorNorm::L1 ? static_cast<float>(L1(a.at(ia), b.at(ib), a.stride, ta, tb))
                                          : std::sqrt(static_cast<float>(L2SQ(a.at(ia), b.at(ib), a.stride, ta, tb)));
    }
};

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#define LIDARFLOW_HAVE_AVX2_PATH 1
// AVX2 kernels (dim is a multiple of 16; 32-byte steps plus one 16-byte tail when needed),
// compiled for AVX2 only in these functions and chosen at run time. The 8-bit and the packed
// kernels share the per-step arithmetic and the horizontal sums below.
__attribute__((target("avx2"))) inline __m256i absdiff_epu8_avx2(__m256i a, __m256i b) {
    return _mm256_or_si256(_mm256_subs_epu8(a, b), _mm256_subs_epu8(b, a));
}

// acc (8 x int32) += the squares of the 32 byte differences of a and b.
__attribute__((target("avx2"))) inline __m256i add_squares_avx2(__m256i acc, __m256i a, __m256i b) {
    const __m256i zero = _mm256_setzero_si256();
    const __m256i d = absdiff_epu8_avx2(a, b);
    const __m256i lo = _mm256_unpacklo_epi8(d, zero), hi = _mm256_unpackhi_epi8(d, zero);
    acc = _mm256_add_epi32(acc, _mm256_madd_epi16(lo, lo));
    return _mm256_add_epi32(acc, _mm256_madd_epi16(hi, hi));
}

__attribute__((target("avx2"))) inline uint32_t hsum256_epi32(__m256i acc) {
    return hsum_epi32(_mm_add_epi32(_mm256_castsi256_si128(acc), _mm256_extracti128_si256(acc, 1)));
}

__attribute__((target("avx2"))) inline uint32_t hsum256_epi64(__m256i acc) {
    const __m128i s = _mm_add_epi64(_mm256_castsi256_si128(acc), _mm256_extracti128_si256(acc, 1));
    return static_cast<uint32_t>(_mm_cvtsi128_si32(s) + _mm_cvtsi128_si32(_mm_srli_si128(s, 8)));
}

__attribute__((target("avx2"))) inline __m256i load256(const uint8_t *p) {
    return _mm256_loadu_si256(reinterpret_cast<const __m256i *>(p));
}

__attribute__((target("avx2"))) inline uint32_t l2sq_avx2(const uint8_t *a, const uint8_t *b, int dim) {
    __m256i acc = _mm256_setzero_si256();
    int i = 0;
    for (; i + 32 <= dim; i += 32) acc = add_squares_avx2(acc, load256(a + i), load256(b + i));
    uint32_t total = hsum256_epi32(acc);
    if (i < dim) total += l2sq(a + i, b + i, dim - i);
    return total;
}

__attribute__((target("avx2"))) inline uint32_t l1_avx2(const uint8_t *a, const uint8_t *b, int dim) {
    __m256i acc = _mm256_setzero_si256();
    int i = 0;
    for (; i + 32 <= dim; i += 32) acc = _mm256_add_epi64(acc, _mm256_sad_epu8(load256(a + i), load256(b + i)));
    uint32_t total = hsum256_epi64(acc);
    if (i < dim) total += l1(a + i, b + i, dim - i);
    return total;
}

// A descriptor's 16 decoded values in both lanes: the table vpshufb looks its codes up in.
__attribute__((target("avx2"))) inline __m256i levels_avx2(const uint8_t *levels) {
    return _mm256_broadcastsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i *>(levels)));
}

// Both nibbles of 32 packed bytes as decoded values.
struct Decoded {
    __m256i lo, hi;
};
__attribute__((target("avx2"))) inline Decoded decode_packed_avx2(const uint8_t *p, __m256i table) {
    const __m256i m = _mm256_set1_epi8(0x0F);
    const __m256i v = load256(p);
    return {_mm256_shuffle_epi8(table, _mm256_and_si256(v, m)),
            _mm256_shuffle_epi8(table, _mm256_and_si256(_mm256_srli_epi16(v, 4), m))};
}

__attribute__((target("avx2"))) inline uint32_t l2sq_packed_avx2(const uint8_t *a, const uint8_t *b, int bytes,
                                                                 const uint8_t *ta, const uint8_t *tb) {
    const __m256i la = levels_avx2(ta), lb = levels_avx2(tb);
    __m256i acc = _mm256_setzero_si256();
    int i = 0;
    for (; i + 32 <= bytes; i += 32) {
        const Decoded da = decode_packed_avx2(a + i, la), db = decode_packed_avx2(b + i, lb);
        acc = add_squares_avx2(acc, da.lo, db.lo);
        acc = add_squares_avx2(acc, da.hi, db.hi);
    }
    uint32_t total = hsum256_epi32(acc);
    if (i < bytes) total += l2sq_packed(a + i, b + i, bytes - i, ta, tb);
    return total;
}

__attribute__((target("avx2"))) inline uint32_t l1_packed_avx2(const uint8_t *a, const uint8_t *b, int bytes,
                                                               const uint8_t *ta, const uint8_t *tb) {
    const __m256i la = levels_avx2(ta), lb = levels_avx2(tb);
    __m256i acc = _mm256_setzero_si256();
    int i = 0;
    for (; i + 32 <= bytes; i += 32) {
        const Decoded da = decode_packed_avx2(a + i, la), db = decode_packed_avx2(b + i, lb);
        acc = _mm256_add_epi64(acc, _mm256_sad_epu8(da.lo, db.lo));
        acc = _mm256_add_epi64(acc, _mm256_sad_epu8(da.hi, db.hi));
    }
    uint32_t total = hsum256_epi64(acc);
    if (i < bytes) total += l1_packed(a + i, b + i, bytes - i, ta, tb);
    return total;
}

// acc (8 x int32 per sample) of up to four samples -> their four sums, in order.
__attribute__((target("avx2"))) inline __m128i hsum4_avx2(__m256i a0, __m256i a1, __m256i a2, __m256i a3) {
    const __m256i t = _mm256_hadd_epi32(_mm256_hadd_epi32(a0, a1), _mm256_hadd_epi32(a2, a3));
    return _mm_add_epi32(_mm256_castsi256_si128(t), _mm256_extracti128_si256(t, 1));
}

// Squared distances of the 128-byte descriptors of three samples, computed side by side.
__attribute__((target("avx2"))) inline __m128 l2sq3_128_avx2(const uint8_t *a0, const uint8_t *b0,
                                                             const uint8_t *a1, const uint8_t *b1,
                                                             const uint8_t *a2, const uint8_t *b2) {
    __m256i s0 = _mm256_setzero_si256(), s1 = s0, s2 = s0;
    for (int i = 0; i < 128; i += 32) {
        s0 = add_squares_avx2(s0, load256(a0 + i), load256(b0 + i));
        s1 = add_squares_avx2(s1, load256(a1 + i), load256(b1 + i));
        s2 = add_squares_avx2(s2, load256(a2 + i), load256(b2 + i));
    }
    // Sums <= 128 * 255^2 < 2^24: exact in float, as in the one-sample kernel.
    return _mm_cvtepi32_ps(hsum4_avx2(s0, s1, s2, _mm256_setzero_si256()));
}

// Eq. 2 for 128-byte 8-bit descriptors and the Euclidean distance, the layout and norm of every
// preset, with the whole patch inside both images. The one-sample loop spent most of its time
// in the chain of one sample's reduction, square root and bound test (~35 cycles per sample on
// data in L1); here three samples' distances are computed independently and their roots taken
// together. The sum is still accumulated sample by sample in the same order, and a bound test
// after every three samples returns a partial sum > bound exactly when the one-sample loop
// would (the partial sums only grow), so costs and decisions are bit-identical.
__attribute__((target("avx2"))) inline float patch_l2_128_avx2(const View &a, ptrdiff_t ca, const View &b,
                                                               ptrdiff_t cb, const PatchShape &shape, float bound) {
    const int n = shape.samples();
    const int *dx = shape.dx.data(), *dy = shape.dy.data();
    const uint8_t *pa[3], *pb[3];
    float sum = 0.0f;
    int k = 0;
    for (; k + 3 <= n; k += 3) {
        for (int j = 0; j < 3; ++j) {
            pa[j] = a.at(ca + dy[k + j] * a.width + dx[k + j]);
            pb[j] = b.at(cb + dy[k + j] * b.width + dx[k + j]);
        }
        alignas(16) float d[4];
        _mm_store_ps(d, _mm_sqrt_ps(l2sq3_128_avx2(pa[0], pb[0], pa[1], pb[1], pa[2], pb[2])));
        sum += d[0];
        sum += d[1];
        sum += d[2];
        if (sum > bound) return sum;
    }
    for (; k < n; ++k) {
        sum += std::sqrt(static_cast<float>(l2sq_avx2(a.at(ca + dy[k] * a.width + dx[k]),
                                                      b.at(cb + dy[k] * b.width + dx[k]), 128)));
        if (sum > bound) return sum;
    }
    return sum;
}

struct ByteKernelAvx2 : ByteKernel<l2sq_avx2, l1_avx2> {
    __attribute__((target("avx2"))) static bool whole_patch(const View &a, ptrdiff_t ca, const View &b,
                                                            ptrdiff_t cb, const PatchShape &shape,
                                                            DescriptorNorm norm, float bound, float &cost) {
        if (a.stride != 128 || norm != DescriptorNorm::L2) return false;
        cost = patch_l2_128_avx2(a, ca, b, cb, shape, bound);
        return true;
    }
};

// flatten: the generic patch loop and the AVX2 kernels are inlined into one AVX2 function.
template <class K>
__attribute__((target("avx2"), flatten)) float patch_cost_avx2(const features::DescriptorImage &a,
                                                      const features::DescriptorImage &b, int ax, int ay,
                                                      int bx, int by, const PatchShape &shape,
                                                      DescriptorNorm norm, float penalty, float bound) {
    return patch_cost_impl<K>(a, b, ax, ay, bx, by, shape, norm, penalty, bound);
}

#endif

template <class K>
float patch_cost_sse2(const features::DescriptorImage &a, const features::DescriptorImage &b, int ax, int ay,
                      int bx, int by, const PatchShape &shape, DescriptorNorm norm, float penalty, float bound) {
    return patch_cost_impl<K>(a, b, ax, ay, bx, by, shape, norm, penalty, bound);
}

}  // namespace

// The descriptor layout is chosen here, once per caller (the matcher keeps the function), so
// each kernel is one straight loop for one layout.
PatchCostFn patch_cost_baseline_kernel(int bits) {
    return bits == 4 ? patch_cost_sse2<PackedKernel<l2sq_packed, l1_packed>> : patch_cost_sse2<ByteKernel<l2sq, l1>>;
}

PatchCostFn patch_cost_kernel(int bits) {
#ifdef LIDARFLOW_HAVE_AVX2_PATH
    if (cpu_has_avx2())
        return bits == 4 ? patch_cost_avx2<PackedKernel<l2sq_packed_avx2, l1_packed_avx2>>
                         : patch_cost_avx2<ByteKernelAvx2>;
#endif
    return patch_cost_baseline_kernel(bits);
}

float patch_cost(const features::DescriptorImage &a, const features::DescriptorImage &b, int ax,
                 int ay, int bx, int by, const PatchShape &shape, DescriptorNorm norm,
                 float penalty, float bound) {
    return patch_cost_kernel(a.bits)(a, b, ax, ay, bx, by, shape, norm, penalty, bound);
}

}  // namespace lidarflow::matching
