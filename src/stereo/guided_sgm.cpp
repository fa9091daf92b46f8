// SPDX-License-Identifier: MIT
#include "stereo/guided_sgm.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include <omp.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/cpu_dispatch.hpp"
#include "core/error.hpp"
#include "core/gray.hpp"
#include "core/limits.hpp"
#include "core/maps.hpp"
#include "core/rounding.hpp"

namespace lidarflow::stereo {
namespace {

constexpr int kCensusHalfW = 4, kCensusHalfH = 3;  // 9x7 window: 62 bits
constexpr uint16_t kBig = 0x3FFF;                  // path sentinel: + P1 still fits 16 bits

// Census signatures of one row: bit 61 - q of `dark` set when neighbour q of the 9x7 window (in
// raster order, the centre left out) is darker than the centre by more than `t` grey levels; of
// `bright` (when not null) when it is brighter by more than `t`. `rows` are the window's 7 rows of
// the padded image (kCensusHalfW replicated pixels each side), so the loops over x have no border
// case. The bits are collected a byte at a time in 8-bit lanes (32 pixels an AVX2 step) and the
// eight bytes joined at the end: the 64-bit lanes of one pass per neighbour were 8x the work.
// `scratch`: 16 * w bytes.
LIDARFLOW_V3_CLONES
void census_row(const uint8_t *const *rows, int w, int t, uint64_t *dark, uint64_t *bright, uint8_t *scratch) {
    const uint8_t *centre = rows[kCensusHalfH] + kCensusHalfW;
    uint8_t *below = scratch, *above = scratch + w;  // centre - t and centre + t, saturated
    uint8_t *dark_bytes = scratch + 2 * static_cast<size_t>(w);
    uint8_t *bright_bytes = dark_bytes + 8 * static_cast<size_t>(w);
    // n + t < c  <=>  n < max(c - t, 0);  n > c + t  <=>  n > min(c + t, 255) (no n exceeds 255).
    for (int x = 0; x < w; ++x) {
        below[x] = static_cast<uint8_t>(std::max(centre[x] - t, 0));
        above[x] = static_cast<uint8_t>(std::min(centre[x] + t, 255));
    }
    std::fill(dark_bytes, dark_bytes + 8 * static_cast<size_t>(w), 0);
    if (bright) std::fill(bright_bytes, bright_bytes + 8 * static_cast<size_t>(w), 0);
    int q = 0;
    for (int k = 0; k < 2 * kCensusHalfH + 1; ++k)
        for (int j = 0; j < 2 * kCensusHalfW + 1; ++j) {
            if (k == kCensusHalfH && j == kCensusHalfW) continue;
            const uint8_t *n = rows[k] + j;
            const size_t byte = static_cast<size_t>((61 - q) / 8) * w;  // the byte holding bit 61 - q
            ++q;
            uint8_t *d = dark_bytes + byte;
            for (int x = 0; x < w; ++x) d[x] = static_cast<uint8_t>((d[x] << 1) | (n[x] < below[x]));
            if (bright) {
                uint8_t *b = bright_bytes + byte;
                for (int x = 0; x < w; ++x) b[x] = static_cast<uint8_t>((b[x] << 1) | (n[x] > above[x]));
            }
        }
    auto join = [w](const uint8_t *bytes, uint64_t *out) {
        for (int x = 0; x < w; ++x) {
            uint64_t v = 0;
            for (int m = 0; m < 8; ++m) v |= static_cast<uint64_t>(bytes[static_cast<size_t>(m) * w + x]) << (8 * m);
            out[x] = v;
        }
    };
    join(dark_bytes, dark);
    if (bright) join(bright_bytes, bright);
}

// Census signatures of an image (8 bytes per pixel and plane, read as uint64), the window
// clamped at the border (replicated pixels). `bright` stays empty unless `ternary`.
struct Census {
    cv::Mat dark, bright;
};
Census census(const cv::Mat1b &g, int t, bool ternary, int threads) {
    const int h = g.rows, w = g.cols;
    cv::Mat1b padded;
    cv::copyMakeBorder(g, padded, kCensusHalfH, kCensusHalfH, kCensusHalfW, kCensusHalfW, cv::BORDER_REPLICATE);
    Census c{cv::Mat(h, w, CV_64F), ternary ? cv::Mat(h, w, CV_64F) : cv::Mat()};
    std::vector<std::vector<uint8_t>> scratch(threads, std::vector<uint8_t>(16 * static_cast<size_t>(w) + 2 * w));
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int y = 0; y < h; ++y) {
        uint8_t *work = scratch[static_cast<size_t>(omp_get_thread_num())].data();
        const uint8_t *rows[2 * kCensusHalfH + 1];
        for (int k = 0; k < 2 * kCensusHalfH + 1; ++k) rows[k] = padded.ptr<uint8_t>(y + k);
        census_row(rows, w, t, c.dark.ptr<uint64_t>(y), ternary ? c.bright.ptr<uint64_t>(y) : nullptr, work);
    }
    return c;
}

// Hamming distance of two pixels' signatures, 0..62: with two planes a neighbour counts 1 where
// one side sees it within the threshold and 2 where it flips, halved so that P1, P2 and the
// LiDAR term keep their scale.
template <bool Ternary>
inline uint8_t hamming(const uint64_t *dl, const uint64_t *bl, const uint64_t *dr, const uint64_t *br, int xl, int xr) {
    if (!Ternary) return static_cast<uint8_t>(__builtin_popcountll(dl[xl] ^ dr[xr]));
    const int n = __builtin_popcountll(dl[xl] ^ dr[xr]) + __builtin_popcountll(bl[xl] ^ br[xr]);
    return static_cast<uint8_t>((n + 1) >> 1);
}

// The smallest |16 d - p16| at which the penalty reaches its cap (0 when it is always 0).
inline uint16_t penalty_reach(int slope16, int cap) {
    return static_cast<uint16_t>(slope16 > 0 ? std::min((cap * 256 + slope16 - 1) / slope16, 0xFFFF) : 0);
}

// c[d] += round(wt * min(slope16 * |16 d - p16| / 256, cap) / 255), saturated at 255, in 16-bit
// lanes: |16 d - p16| is clamped at `top` (penalty_reach: where the penalty reaches the cap), so
// the products fit 16 bits, and x / 255 is (x + 1 + (x >> 8)) >> 8, exact for x < 65535.
// The penalty's byte at a clamped distance diff <= top (w: weight, s: slope16, cp: cap).
inline uint16_t penalty_at(uint16_t diff, uint16_t w, uint16_t s, uint16_t cp) {
    const uint16_t pen = std::min(static_cast<uint16_t>(static_cast<uint16_t>(s * diff) >> 8), cp);
    const auto x = static_cast<uint16_t>(w * pen + 127);
    return static_cast<uint16_t>((x + 1 + (x >> 8)) >> 8);
}

inline void add_lidar_penalty(uint8_t *c, int D, int p16, int wt, int slope16, uint16_t top, int cap) {
    const auto p = static_cast<uint16_t>(p16), w = static_cast<uint16_t>(wt), s = static_cast<uint16_t>(slope16),
               cp = static_cast<uint16_t>(cap);
    for (int d = 0; d < D; ++d) {
        const auto at = static_cast<uint16_t>(16 * d);
        const uint16_t q = penalty_at(std::min(static_cast<uint16_t>(at > p ? at - p : p - at), top), w, s, cp);
        c[d] = static_cast<uint8_t>(std::min(255, c[d] + q));
    }
}

#if defined(__x86_64__) || defined(__i386__)
// add_lidar_penalty where D >= 32 and the penalty rises over fewer than 32 disparities (top <=
// 240): beyond that span every d takes the capped penalty, one saturated byte add per 16, and the
// 32 around the prior take the exact one, computed from the costs before the add.
__attribute__((target("avx2"))) inline void add_lidar_penalty_avx2(uint8_t *c, int D, int p16, int wt, int slope16,
                                                                   uint16_t top, int cap) {
    // The span |16 d - p16| < top lies in [(p16 - top) / 16, (p16 + top) / 16]: 32 values from
    // `start` hold it (or the part of it inside [0, D)).
    const int start = std::clamp((p16 - top) / 16, 0, D - 32);
    const __m256i p = _mm256_set1_epi16(static_cast<int16_t>(p16));
    const __m256i s = _mm256_set1_epi16(static_cast<int16_t>(slope16)), w = _mm256_set1_epi16(static_cast<int16_t>(wt));
    const __m256i lim = _mm256_set1_epi16(static_cast<int16_t>(top)), cp = _mm256_set1_epi16(static_cast<int16_t>(cap));
    const __m256i half = _mm256_set1_epi16(127), one = _mm256_set1_epi16(1), step16 = _mm256_set1_epi16(16 * 16);
    __m256i at = _mm256_add_epi16(_mm256_set1_epi16(static_cast<int16_t>(16 * start)),
                                  _mm256_setr_epi16(0, 16, 32, 48, 64, 80, 96, 112, 128, 144, 160, 176, 192, 208,
                                                    224, 240));
    __m256i q[2];
    for (__m256i &qi : q) {
        const __m256i diff = _mm256_min_epu16(_mm256_sub_epi16(_mm256_max_epu16(at, p), _mm256_min_epu16(at, p)), lim);
        const __m256i pen = _mm256_min_epu16(_mm256_srli_epi16(_mm256_mullo_epi16(s, diff), 8), cp);
        const __m256i x = _mm256_add_epi16(_mm256_mullo_epi16(w, pen), half);
        qi = _mm256_srli_epi16(_mm256_add_epi16(_mm256_add_epi16(x, one), _mm256_srli_epi16(x, 8)), 8);
        at = _mm256_add_epi16(at, step16);
    }
    const __m256i exact = _mm256_adds_epu8(_mm256_loadu_si256(reinterpret_cast<const __m256i *>(c + start)),
                                           _mm256_permute4x64_epi64(_mm256_packus_epi16(q[0], q[1]), 0xD8));
    // The capped penalty: the exact one at |16 d - p16| >= top.
    const uint16_t capped = penalty_at(top, static_cast<uint16_t>(wt), static_cast<uint16_t>(slope16),
                                       static_cast<uint16_t>(cap));
    const __m128i far = _mm_set1_epi8(static_cast<char>(capped));
    for (int d = 0; d < D; d += 16) {
        __m128i *v = reinterpret_cast<__m128i *>(c + d);
        _mm_storeu_si128(v, _mm_adds_epu8(_mm_loadu_si128(v), far));
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i *>(c + start), exact);
}
#endif

// The Hamming costs of pixels [x0, x1) of one row: cost[x * D + d] = Hamming(left x, right x - d),
// the right image's column 0 standing in left of the image. bl, br: the bright planes (Ternary
// only). Integer only.
template <bool Ternary>
inline __attribute__((always_inline)) void hamming_costs_of(const uint64_t *dl, const uint64_t *dr, const uint64_t *bl,
                                                           const uint64_t *br, int x0, int x1, int D, uint8_t *cost) {
    for (int x = x0; x < x1; ++x) {
        uint8_t *c = cost + static_cast<size_t>(x) * D;
        const int lim = std::min(D, x + 1);
        for (int d = 0; d < lim; ++d) c[d] = hamming<Ternary>(dl, bl, dr, br, x, x - d);
        const uint8_t edge = hamming<Ternary>(dl, bl, dr, br, x, 0);
        for (int d = lim; d < D; ++d) c[d] = edge;
    }
}

#if defined(__x86_64__) || defined(__i386__)
// Bit counts of each byte of v (nibble table lookups).
__attribute__((target("avx2"))) inline __m256i byte_popcounts(__m256i v) {
    const __m256i table = _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4, 0, 1, 1, 2, 1, 2, 2, 3, 1,
                                           2, 2, 3, 2, 3, 3, 4);
    const __m256i nibble = _mm256_set1_epi8(0x0F);
    return _mm256_add_epi8(_mm256_shuffle_epi8(table, _mm256_and_si256(v, nibble)),
                           _mm256_shuffle_epi8(table, _mm256_and_si256(_mm256_srli_epi16(v, 4), nibble)));
}

// hamming_costs_of for x >= D - 1 (every disparity has its own right pixel), 16 disparities a
// step: group g's four right pixels x - d - 4g - 3 .. x - d - 4g are one load (lane k holds
// disparity d + 4g + 3 - k), their counts summed per 64-bit lane, and the 16 counts put in order
// by one byte shuffle. The same integers as the scalar loop.
template <bool Ternary>
__attribute__((target("avx2"))) inline void hamming_costs_avx2(const uint64_t *dl, const uint64_t *dr,
                                                              const uint64_t *bl, const uint64_t *br, int x0, int x1,
                                                              int D, uint8_t *cost) {
    const __m256i zero = _mm256_setzero_si256();
    const __m256i dwords = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    // Byte 4k + g of the gathered dwords is disparity d + 4g + 3 - k; out byte 4g + k' takes it
    // with k = 3 - k'.
    const __m128i order = _mm_setr_epi8(12, 8, 4, 0, 13, 9, 5, 1, 14, 10, 6, 2, 15, 11, 7, 3);
    for (int x = x0; x < x1; ++x) {
        const __m256i l = _mm256_set1_epi64x(static_cast<long long>(dl[x]));
        const __m256i lb = Ternary ? _mm256_set1_epi64x(static_cast<long long>(bl[x])) : zero;
        uint8_t *c = cost + static_cast<size_t>(x) * D;
        for (int d = 0; d < D; d += 16) {
            __m256i packed = zero;
            for (int g = 0; g < 4; ++g) {
                const size_t at = static_cast<size_t>(x - d - 4 * g - 3);
                __m256i bits = byte_popcounts(
                    _mm256_xor_si256(l, _mm256_loadu_si256(reinterpret_cast<const __m256i *>(dr + at))));
                if (Ternary) {
                    const __m256i right = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(br + at));
                    bits = _mm256_add_epi8(bits, byte_popcounts(_mm256_xor_si256(lb, right)));
                }
                packed = _mm256_or_si256(packed, _mm256_slli_epi64(_mm256_sad_epu8(bits, zero), 8 * g));
            }
            __m128i out = _mm_shuffle_epi8(_mm256_castsi256_si128(_mm256_permutevar8x32_epi32(packed, dwords)), order);
            if (Ternary) out = _mm_avg_epu8(out, _mm_setzero_si128());  // (n + 1) >> 1
            _mm_storeu_si128(reinterpret_cast<__m128i *>(c + d), out);
        }
    }
}
#endif

// The Hamming costs on the vector path where `simd` and the CPU has AVX2, from pixel D - 1 on (the
// pixels before it read column 0 for some disparities), then the LiDAR penalty.
LIDARFLOW_V3_CLONES void row_costs_cloned(bool ternary, const uint64_t *dl, const uint64_t *dr, const uint64_t *bl,
                                          const uint64_t *br, const int16_t *prior16, const uint8_t *weight, int w,
                                          int D, int slope16, int cap, bool simd, uint8_t *cost) {
    const int scalar_end = simd && cpu_has_avx2() ? std::min(w, D - 1) : w;
    if (ternary)
        hamming_costs_of<true>(dl, dr, bl, br, 0, scalar_end, D, cost);
    else
        hamming_costs_of<false>(dl, dr, bl, br, 0, scalar_end, D, cost);
#if defined(__x86_64__) || defined(__i386__)
    if (scalar_end < w) {
        if (ternary)
            hamming_costs_avx2<true>(dl, dr, bl, br, scalar_end, w, D, cost);
        else
            hamming_costs_avx2<false>(dl, dr, bl, br, scalar_end, w, D, cost);
    }
#endif
    const uint16_t top = penalty_reach(slope16, cap);
#if defined(__x86_64__) || defined(__i386__)
    if (simd && cpu_has_avx2() && D >= 32 && top <= 240) {
        for (int x = 0; x < w; ++x)
            if (weight[x] != 0)
                add_lidar_penalty_avx2(cost + static_cast<size_t>(x) * D, D, prior16[x], weight[x], slope16, top, cap);
        return;
    }
#endif
    for (int x = 0; x < w; ++x)
        if (weight[x] != 0)
            add_lidar_penalty(cost + static_cast<size_t>(x) * D, D, prior16[x], weight[x], slope16, top, cap);
}

}  // namespace

// The tests' entry to the cloned kernel (core/cpu_dispatch.hpp: clones stay internal).
void detail::row_costs(bool ternary, const uint64_t *dl, const uint64_t *dr, const uint64_t *bl, const uint64_t *br,
                       const int16_t *prior16, const uint8_t *weight, int w, int D, int slope16, int cap, bool simd,
                       uint8_t *cost) {
    row_costs_cloned(ternary, dl, dr, bl, br, prior16, weight, w, D, slope16, cap, simd, cost);
}

namespace {

// One step along a path: cur = cost + min(prev, prev(d +- 1) + P1, min(prev) + P2) - min(prev),
// added into sum (or stored there when `first`). prev has a sentinel at [-1] and [D]. Returns
// min(cur).
template <bool First>
inline uint16_t path_step(const uint8_t *__restrict c, const uint16_t *__restrict prev, uint16_t prev_min, uint16_t p1,
                          uint16_t p2, uint16_t *__restrict cur, uint16_t *__restrict sum, int D) {
    const uint16_t jump = static_cast<uint16_t>(prev_min + p2);
    uint16_t m = kBig;
    for (int d = 0; d < D; ++d) {
        uint16_t v = std::min<uint16_t>(prev[d], static_cast<uint16_t>(std::min(prev[d - 1], prev[d + 1]) + p1));
        v = std::min(v, jump);
        const uint16_t out = static_cast<uint16_t>(c[d] + v - prev_min);
        cur[d] = out;
        m = std::min(m, out);
        if (First)
            sum[d] = out;
        else
            sum[d] = static_cast<uint16_t>(sum[d] + out);
    }
    return m;
}

struct Penalties {
    uint16_t p1, p2;
    bool adaptive;
    uint16_t p2_at(int step) const {  // step: |I(p) - I(p - r)|
        if (!adaptive) return p2;
        return static_cast<uint16_t>(std::max<int>(p1 + 1, p2 * 8 / (8 + step)));
    }
};

// A path buffer of n pixels: D + 2 values each, sentinels at both ends, zeros inside (the first
// pixel of a path then takes its data cost alone).
struct PathRow {
    std::vector<uint16_t> v;
    std::vector<uint16_t> min;
    int stride;
    PathRow(int n, int D) : v(static_cast<size_t>(n) * (D + 2), 0), min(n, 0), stride(D + 2) {
        for (int i = 0; i < n; ++i) {
            v[static_cast<size_t>(i) * stride] = kBig;
            v[static_cast<size_t>(i) * stride + D + 1] = kBig;
        }
    }
    uint16_t *at(int i) { return v.data() + static_cast<size_t>(i) * stride + 1; }
};

// Both directions along each row; the first writes the sums. a, b: two path buffers of one
// pixel (PathRow::at); each direction starts from zeros (its first pixel takes its data cost).
LIDARFLOW_V3_CLONES
void horizontal_paths(const uint8_t *cost, const uint8_t *img, int w, int D, const Penalties &pen, uint16_t *sum,
                      uint16_t *a, uint16_t *b) {
    uint16_t *prev = a, *cur = b, prev_min = 0;
    std::fill(prev, prev + D, 0);
    for (int x = 0; x < w; ++x) {
        const uint16_t p2 = pen.p2_at(x ? std::abs(img[x] - img[x - 1]) : 0);
        prev_min = path_step<true>(cost + static_cast<size_t>(x) * D, prev, prev_min, pen.p1, p2, cur,
                                   sum + static_cast<size_t>(x) * D, D);
        std::swap(prev, cur);
    }
    std::fill(prev, prev + D, 0);
    prev_min = 0;
    for (int x = w - 1; x >= 0; --x) {
        const uint16_t p2 = pen.p2_at(x + 1 < w ? std::abs(img[x] - img[x + 1]) : 0);
        prev_min = path_step<false>(cost + static_cast<size_t>(x) * D, prev, prev_min, pen.p1, p2, cur,
                                    sum + static_cast<size_t>(x) * D, D);
        std::swap(prev, cur);
    }
}

#if defined(__x86_64__) || defined(__i386__)
// The least of 16 unsigned 16-bit lanes.
__attribute__((target("avx2"))) inline uint16_t least_u16(__m256i v) {
    const __m128i m8 = _mm_min_epu16(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
    return static_cast<uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m8)));
}

// f(std::integral_constant<int, NV>{}) for a kernel templated on its vector count NV = D / 16
// (D a multiple of 16 in [16, 128]).
template <class F>
void with_vector_count(int D, F &&f) {
    switch (D / 16) {
    case 1: return f(std::integral_constant<int, 1>{});
    case 2: return f(std::integral_constant<int, 2>{});
    case 3: return f(std::integral_constant<int, 3>{});
    case 4: return f(std::integral_constant<int, 4>{});
    case 5: return f(std::integral_constant<int, 5>{});
    case 6: return f(std::integral_constant<int, 6>{});
    case 7: return f(std::integral_constant<int, 7>{});
    default: return f(std::integral_constant<int, 8>{});
    }
}

// horizontal_paths with the path in registers, NV vectors of 16 disparities (D = 16 NV): the
// scalar loop reloads the path it has just stored one disparity off, a load the CPU cannot
// forward from the store, so every step waited on memory; here d - 1 and d + 1 are shuffled out
// of the registers (two instructions each). The same integers as the scalar loop.
template <int NV>
__attribute__((target("avx2"))) void horizontal_paths_avx2(const uint8_t *cost, const uint8_t *img, int w,
                                                           const Penalties &pen, uint16_t *sum) {
    constexpr int D = 16 * NV;
    const __m256i big = _mm256_set1_epi16(static_cast<short>(kBig)), p1 = _mm256_set1_epi16(static_cast<short>(pen.p1));
    for (int dir = 0; dir < 2; ++dir) {
        __m256i P[NV];
        for (__m256i &v : P) v = _mm256_setzero_si256();
        uint16_t prev_min = 0;
        for (int i = 0; i < w; ++i) {
            const int x = dir == 0 ? i : w - 1 - i;
            const uint16_t p2 = pen.p2_at(i ? std::abs(img[x] - img[dir == 0 ? x - 1 : x + 1]) : 0);
            const __m256i jump = _mm256_set1_epi16(static_cast<short>(static_cast<uint16_t>(prev_min + p2)));
            const __m256i pm = _mm256_set1_epi16(static_cast<short>(prev_min));
            const uint8_t *c = cost + static_cast<size_t>(x) * D;
            uint16_t *s = sum + static_cast<size_t>(x) * D;
            __m256i out[NV], m = big;
            for (int k = 0; k < NV; ++k) {
                // Lane j of `left` holds d - 1, of `right` d + 1 (kBig past either end).
                const __m256i before = k > 0 ? P[k - 1] : big, after = k + 1 < NV ? P[k + 1] : big;
                const __m256i left = _mm256_alignr_epi8(P[k], _mm256_permute2x128_si256(before, P[k], 0x21), 14);
                const __m256i right = _mm256_alignr_epi8(_mm256_permute2x128_si256(P[k], after, 0x21), P[k], 2);
                __m256i v = _mm256_min_epu16(P[k], _mm256_add_epi16(_mm256_min_epu16(left, right), p1));
                v = _mm256_min_epu16(v, jump);
                const __m256i ck = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i *>(c + 16 * k)));
                out[k] = _mm256_sub_epi16(_mm256_add_epi16(ck, v), pm);
                m = _mm256_min_epu16(m, out[k]);
                auto *sk = reinterpret_cast<__m256i *>(s + 16 * k);
                _mm256_storeu_si256(sk, dir == 0 ? out[k] : _mm256_add_epi16(_mm256_loadu_si256(sk), out[k]));
            }
            for (int k = 0; k < NV; ++k) P[k] = out[k];
            prev_min = least_u16(m);
        }
    }
}
#endif

// Both horizontal paths of one row: the register kernel where the CPU has AVX2 and D <= 128, else
// the scalar loop (a, b: its two path buffers).
void horizontal_paths_of(const uint8_t *cost, const uint8_t *img, int w, int D, const Penalties &pen, bool simd,
                         uint16_t *sum, uint16_t *a, uint16_t *b) {
#if defined(__x86_64__) || defined(__i386__)
    if (simd && D <= 128 && cpu_has_avx2())
        return with_vector_count(D, [&](auto nv) { horizontal_paths_avx2<nv()>(cost, img, w, pen, sum); });
#endif
    horizontal_paths(cost, img, w, D, pen, sum, a, b);
}

}  // namespace

void detail::horizontal_paths(const uint8_t *cost, const uint8_t *img, int w, int D, int p1, int p2, bool adaptive_p2,
                              bool simd, uint16_t *sum) {
    PathRow scratch(2, D);
    horizontal_paths_of(cost, img, w, D, Penalties{static_cast<uint16_t>(p1), static_cast<uint16_t>(p2), adaptive_p2},
                        simd, sum, scratch.at(0), scratch.at(1));
}

namespace {

// The vertical and (with 8 paths) diagonal paths entering row y from row y - dir, for columns
// [x0, x1). prev*: row y - dir's paths; cur*: row y's. A path that starts here (the first row,
// a diagonal from outside the image) continues from `zero`, which gives it its data cost alone.
LIDARFLOW_V3_CLONES
void column_paths(const uint8_t *cost, const uint8_t *img, const uint8_t *img_prev, int w, int D, const Penalties &pen,
                  bool diagonals, bool first_row, PathRow &zero, PathRow &pv, PathRow &cv_, PathRow &pa, PathRow &ca,
                  PathRow &pb, PathRow &cb, uint16_t *sum, int x0, int x1) {
    for (int x = x0; x < x1; ++x) {
        const uint8_t *c = cost + static_cast<size_t>(x) * D;
        uint16_t *s = sum + static_cast<size_t>(x) * D;
        // One step from column `from` of the previous row's path `prev` into `cur`.
        auto step = [&](PathRow &prev, int from, PathRow &cur) {
            const bool start = first_row || from < 0 || from >= w;
            const int at = start ? 0 : from;
            PathRow &p = start ? zero : prev;
            cur.min[x] = path_step<false>(c, p.at(at), p.min[at], pen.p1,
                                          pen.p2_at(start ? 0 : std::abs(img[x] - img_prev[from])), cur.at(x), s, D);
        };
        step(pv, x, cv_);
        if (!diagonals) continue;
        step(pa, x - 1, ca);
        step(pb, x + 1, cb);
    }
}

// Pixel x's winner (-1 when not unique: a sum more than 1 px away within the uniqueness margin,
// or no such rival, as in the first columns) from its sums s over lim disparities, and its offers
// to the right image's pixels x - d: (sum, d) replaces (rsum, rd) there when the sum is smaller.
// The pixels come in order of x, so of equal sums a right pixel keeps the smallest d.
inline void pixel_winner(const uint16_t *s, int x, int lim, int uniqueness, uint16_t *rsum, uint16_t *rd,
                         int16_t *best) {
    // Loops without branches on the sums, so that they vectorise.
    uint16_t bs = UINT16_MAX;
    for (int d = 0; d < lim; ++d) bs = std::min(bs, s[d]);
    int b = 0;
    while (s[b] != bs) ++b;
    uint32_t other = UINT32_MAX;
    for (int d = 0; d < lim; ++d) other = std::min<uint32_t>(other, d < b - 1 || d > b + 1 ? s[d] : UINT32_MAX);
    // Offers in order of the right pixels: e = 0 is x - (lim - 1), disparity lim - 1.
    uint16_t *rs = rsum + x - (lim - 1), *rds = rd + x - (lim - 1);
    for (int e = 0; e < lim; ++e) {
        const uint16_t v = s[lim - 1 - e];
        const bool less = v < rs[e];
        rds[e] = less ? static_cast<uint16_t>(lim - 1 - e) : rds[e];
        rs[e] = less ? v : rs[e];
    }
    best[x] = static_cast<int16_t>(
        other == UINT32_MAX || uint64_t{other} * (100 - uniqueness) <= uint64_t{100} * bs ? -1 : b);
}

#if defined(__x86_64__) || defined(__i386__)
// pixel_winner for every pixel of the row, NV vectors of 16 disparities (D = 16 NV): the first
// least sum by an unsigned 16-bit minimum (phminposuw) and a compare; the rivals' minimum with
// the lanes b - 1 .. b + 1 set to 0xFFFF; each vector's offers reversed onto the 16 right
// pixels it reaches. Left of pixel D - 1 the disparities from x + 1 on read as 0xFFFF (a sum of
// 0xFFFF ties them, and d = 0 wins that tie either way) and their offers land left of the row,
// in the D values rsum and rd have before it. The same integers as the scalar loop.
template <int NV>
__attribute__((target("avx2"))) void winners_avx2(const uint16_t *S, int w, int uniqueness, uint16_t *rsum,
                                                  uint16_t *rd, int16_t *best) {
    constexpr int D = 16 * NV;
    // Per vector k: its lanes' disparities, in order and reversed (the offers' order).
    __m256i up[NV], down[NV];
    for (int k = 0; k < NV; ++k) {
        const __m256i first = _mm256_set1_epi16(static_cast<short>(16 * k));
        up[k] = _mm256_add_epi16(_mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15), first);
        down[k] = _mm256_add_epi16(_mm256_setr_epi16(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0), first);
    }
    const __m256i reverse8 = _mm256_setr_epi8(14, 15, 12, 13, 10, 11, 8, 9, 6, 7, 4, 5, 2, 3, 0, 1, 14, 15, 12, 13, 10,
                                              11, 8, 9, 6, 7, 4, 5, 2, 3, 0, 1);
    const __m256i two = _mm256_set1_epi16(2);
    for (int x = 0; x < w; ++x) {
        const uint16_t *s = S + static_cast<size_t>(x) * D;
        const int lim = std::min(D, x + 1);
        __m256i v[NV];
        for (int k = 0; k < NV; ++k) {
            v[k] = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(s + 16 * k));
            if (lim < D)  // lanes at d >= lim (a signed compare: d < 128)
                v[k] = _mm256_or_si256(v[k], _mm256_cmpgt_epi16(up[k], _mm256_set1_epi16(static_cast<short>(lim - 1))));
        }
        __m256i m = v[0];
        for (int k = 1; k < NV; ++k) m = _mm256_min_epu16(m, v[k]);
        const uint16_t bs = least_u16(m);
        const __m256i bsv = _mm256_set1_epi16(static_cast<short>(bs));
        int b = 0;
        for (int k = 0; k < NV; ++k) {
            const unsigned mask = static_cast<unsigned>(_mm256_movemask_epi8(_mm256_cmpeq_epi16(v[k], bsv)));
            if (mask) {
                b = 16 * k + __builtin_ctz(mask) / 2;
                break;
            }
        }
        // t = d - (b - 1) modulo 2^16 is at most 2 exactly for d in b - 1 .. b + 1.
        const __m256i from = _mm256_set1_epi16(static_cast<short>(b - 1));
        __m256i other = _mm256_set1_epi16(-1);
        for (int k = 0; k < NV; ++k) {
            const __m256i t = _mm256_sub_epi16(up[k], from);
            const __m256i near = _mm256_cmpeq_epi16(_mm256_min_epu16(t, two), t);
            other = _mm256_min_epu16(other, _mm256_or_si256(v[k], near));
        }
        const bool rival = b >= 2 || lim > b + 2;
        best[x] = static_cast<int16_t>(
            !rival || uint64_t{least_u16(other)} * (100 - uniqueness) <= uint64_t{100} * bs ? -1 : b);
        for (int k = 0; k < NV; ++k) {
            // Lane j: disparity 16 k + 15 - j, right pixel x - 16 k - 15 + j.
            const __m256i r = _mm256_shuffle_epi8(v[k], reverse8);
            const __m256i offer = _mm256_permute2x128_si256(r, r, 0x01);
            const int p = x - 16 * k - 15;
            auto *rs = reinterpret_cast<__m256i *>(rsum + p);
            auto *rdp = reinterpret_cast<__m256i *>(rd + p);
            const __m256i held = _mm256_loadu_si256(rs);
            const __m256i not_less = _mm256_cmpeq_epi16(_mm256_max_epu16(offer, held), offer);
            _mm256_storeu_si256(rs, _mm256_min_epu16(offer, held));
            _mm256_storeu_si256(rdp, _mm256_blendv_epi8(down[k], _mm256_loadu_si256(rdp), not_less));
        }
    }
}
#endif

}  // namespace

void detail::row_winners(const uint16_t *S, int w, int D, int uniqueness, int lr_max_diff, bool simd,
                         uint16_t *scratch, int16_t *best) {
    // The right image's pixels' least sum and its d, each after D values of room (left of the row).
    uint16_t *rsum = scratch + D, *rd = scratch + w + 2 * D;
    std::fill(rsum, rsum + w, UINT16_MAX);
    std::fill(rd, rd + w, 0);  // every sum UINT16_MAX: the first offer, d = 0, keeps it
#if defined(__x86_64__) || defined(__i386__)
    if (simd && D <= 128 && cpu_has_avx2())
        with_vector_count(D, [&](auto nv) { winners_avx2<nv()>(S, w, uniqueness, rsum, rd, best); });
    else
#endif
        for (int x = 0; x < w; ++x)
            pixel_winner(S + static_cast<size_t>(x) * D, x, std::min(D, x + 1), uniqueness, rsum, rd, best);
    if (lr_max_diff < 0) return;
    for (int x = 0; x < w; ++x)
        if (best[x] >= 0 && std::abs(rd[x - best[x]] - best[x]) > lr_max_diff) best[x] = -1;
}

namespace {

// A LiDAR point of densify_lidar: column, its pixel's intensity, disparity.
struct SplatPoint {
    int x, intensity;
    float disparity;
};

// The points of one row, dy rows away, into a padded output row (pixel x at x + r): of the
// pixels of similar intensity within the radius (and the point's own), each keeps the nearest
// point, of equally near ones the larger disparity (the nearer surface), so the order of the
// points does not matter. Branch-free over a whole window of `lanes` (>= 2r + 1, a multiple of
// 8) so that it vectorises; lanes beyond the window change nothing.
LIDARFLOW_AVX2_CLONES
void splat_points(const SplatPoint *pts, int n, int dy, int r, int lanes, int max_step, const int *grey, int *dist,
                  float *disp) {
    for (int i = 0; i < n; ++i) {
        const SplatPoint pt = pts[i];
        int *d = dist + pt.x;
        float *v = disp + pt.x;
        const int *g = grey + pt.x;
        for (int k = 0; k < lanes; ++k) {
            // Bitwise, not short-circuit: no branch in the loop.
            const int dd = std::max(std::abs(k - r), dy), dk = d[k];
            const float vk = v[k];
            const int similar = (dd == 0) | (std::abs(g[k] - pt.intensity) <= max_step);
            const int better = (dd < dk) | ((dd == dk) & (pt.disparity > vk));
            const int take = (k <= 2 * r) & similar & better;
            d[k] = take ? dd : dk;
            v[k] = take ? pt.disparity : vk;
        }
    }
}

void check_inputs(const cv::Mat &left, const cv::Mat &right, const SparseLidar &lidar, const GuidedSgmOptions &opt) {
    opt.validate();
    require(!left.empty() && !right.empty(), ErrorCode::InvalidArgument, "guided SGM: empty image");
    require(left.depth() == CV_8U && (left.channels() == 1 || left.channels() == 3 || left.channels() == 4),
            ErrorCode::InvalidArgument, "guided SGM: images must be 8-bit gray, BGR or BGRA");
    require(left.size() == right.size() && left.type() == right.type(), ErrorCode::SizeMismatch,
            "guided SGM: left and right images differ in size or type");
    require(left.cols <= kMaxImageSide && left.rows <= kMaxImageSide, ErrorCode::InvalidArgument,
            "guided SGM: images larger than " + std::to_string(kMaxImageSide) + " px a side");
    lidar.validate(left.cols, left.rows, "guided SGM: lidar");
}

}  // namespace

void GuidedSgmOptions::validate() const {
    require(num_disparities >= 16 && num_disparities <= 512 && num_disparities % 16 == 0, ErrorCode::InvalidArgument,
            "guided SGM: num_disparities must be a multiple of 16 in [16, 512]");
    require(p1 >= 0 && p1 <= 255 && p2 > p1 && p2 <= 1023, ErrorCode::InvalidArgument,
            "guided SGM: penalties must satisfy 0 <= p1 <= 255, p1 < p2 <= 1023");
    require(paths == 4 || paths == 8, ErrorCode::InvalidArgument, "guided SGM: paths must be 4 or 8");
    require(uniqueness_ratio >= 0 && uniqueness_ratio < 100, ErrorCode::InvalidArgument,
            "guided SGM: uniqueness_ratio must be in [0, 100)");
    require(lr_max_diff <= 1024, ErrorCode::InvalidArgument, "guided SGM: lr_max_diff must be <= 1024");
    require(speckle_window >= 0 && speckle_window <= 1000000 && speckle_range >= 0 && speckle_range <= 1024,
            ErrorCode::InvalidArgument, "guided SGM: speckle_window in [0, 1e6], speckle_range in [0, 1024]");
    require(std::isfinite(lidar_slope) && lidar_slope >= 0 && lidar_slope <= 64, ErrorCode::InvalidArgument,
            "guided SGM: lidar_slope must be in [0, 64]");
    require(lidar_cap >= 0 && lidar_cap <= 192, ErrorCode::InvalidArgument, "guided SGM: lidar_cap must be in [0, 192]");
    require(lidar_radius >= 0 && lidar_radius <= 32, ErrorCode::InvalidArgument,
            "guided SGM: lidar_radius must be in [0, 32]");
    require(lidar_intensity >= 0 && lidar_intensity <= 255, ErrorCode::InvalidArgument,
            "guided SGM: lidar_intensity must be in [0, 255]");
    require(census_threshold >= 0 && census_threshold <= 64, ErrorCode::InvalidArgument,
            "guided SGM: census_threshold must be in [0, 64]");
    require(threads >= 1 && threads <= 256, ErrorCode::InvalidArgument, "guided SGM: threads must be in [1, 256]");
}

LidarPrior densify_lidar(const cv::Mat1b &gray, const SparseLidar &lidar, const GuidedSgmOptions &opt) {
    const int h = gray.rows, w = gray.cols, r = opt.lidar_radius, T = opt.threads;
    LidarPrior p{filled(h, w, kInvalidDisparity), cv::Mat1b::zeros(h, w)};
    // Per thread, one row padded by r on the left and by the lanes' overhang on the right, so
    // that every point's window is whole: its Chebyshev distance of the point that set each
    // pixel, the disparity, the intensity.
    const int lanes = (2 * r + 1 + 7) / 8 * 8, padded = w + r + lanes;
    // The points bucketed by row (x, own intensity, disparity), so that each output row is
    // written by one thread; within a row by x modulo `lanes`, so that consecutive windows do not
    // overlap (a load overlapping the store just before it waits for that store to retire). The
    // splat does not depend on the points' order.
    const size_t buckets = static_cast<size_t>(h) * lanes;
    std::vector<int> first(buckets + 1, 0);
    std::vector<SplatPoint> by_row(lidar.points.size());
    const auto bucket = [lanes](const LidarPoint &pt) { return static_cast<size_t>(pt.y) * lanes + pt.x % lanes; };
    for (const LidarPoint &pt : lidar.points) ++first[bucket(pt) + 1];
    for (size_t b = 0; b < buckets; ++b) first[b + 1] += first[b];
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (const LidarPoint &pt : lidar.points) by_row[fill[bucket(pt)]++] = {pt.x, gray(pt.y, pt.x), pt.disparity};
    // The weight falls with the Chebyshev distance of the point that set the pixel.
    std::vector<uint8_t> weight_at(static_cast<size_t>(r) + 1);
    for (int dd = 0; dd <= r; ++dd) weight_at[dd] = static_cast<uint8_t>(255 * (r + 1 - dd) / (r + 1));
    std::vector<std::vector<int>> dist(T, std::vector<int>(padded));
    std::vector<std::vector<float>> disp(T, std::vector<float>(padded));
    std::vector<std::vector<int>> grey(T, std::vector<int>(padded, 0));
    // Rows dealt out in small chunks: a scan covers only the lower part of the image.
#pragma omp parallel for num_threads(T) schedule(static, 4)
    for (int y = 0; y < h; ++y) {
        const size_t t = static_cast<size_t>(omp_get_thread_num());
        int *dr = dist[t].data(), *gr = grey[t].data();
        float *dp = disp[t].data();
        const int py0 = std::max(0, y - r), py1 = std::min(h - 1, y + r);
        const auto row_first = [&](int py) { return first[static_cast<size_t>(py) * lanes]; };
        if (row_first(py0) == row_first(py1 + 1)) continue;  // no point within reach
        std::fill(dr, dr + padded, r + 1);
        std::fill(dp, dp + padded, kInvalidDisparity);
        const uint8_t *g = gray.ptr<uint8_t>(y);
        std::copy(g, g + w, gr + r);
        for (int py = py0; py <= py1; ++py)
            splat_points(by_row.data() + row_first(py), row_first(py + 1) - row_first(py), std::abs(y - py), r,
                         lanes, opt.lidar_intensity, gr, dr, dp);
        float *disparity = p.disparity.ptr<float>(y);
        uint8_t *weight = p.weight.ptr<uint8_t>(y);
        for (int x = 0; x < w; ++x)
            if (dr[x + r] <= r) {
                disparity[x] = dp[x + r];
                weight[x] = weight_at[dr[x + r]];
            }
    }
    return p;
}

DisparityMap guided_sgm(const cv::Mat &left, const cv::Mat &right, const SparseLidar &lidar,
                        const GuidedSgmOptions &opt) {
    check_inputs(left, right, lidar, opt);
    const cv::Mat1b gl = gray8(left), gr = gray8(right);
    const int h = gl.rows, w = gl.cols, D = opt.num_disparities, T = opt.threads;
    const bool ternary = opt.ternary_census;
    const Census cl = census(gl, opt.census_threshold, ternary, T), cr = census(gr, opt.census_threshold, ternary, T);
    const LidarPrior prior = densify_lidar(gl, lidar, opt);
    const int slope16 = static_cast<int>(std::lround(opt.lidar_slope * 16));

    // Every buffer is allocated here, before the parallel regions (their bodies cannot throw).
    const size_t plane = static_cast<size_t>(w) * D;
    std::unique_ptr<uint8_t[]> cost(new uint8_t[plane * h]);  // every element is written
    std::unique_ptr<uint16_t[]> sum(new uint16_t[plane * h]);
    std::vector<std::vector<uint16_t>> wta_scratch(T, std::vector<uint16_t>(2 * (static_cast<size_t>(w) + D)));
    std::vector<std::vector<int16_t>> prior16(T, std::vector<int16_t>(w));  // the row's prior in 1/16 px
#pragma omp parallel for num_threads(T) schedule(static)
    for (int y = 0; y < h; ++y) {
        int16_t *p16 = prior16[static_cast<size_t>(omp_get_thread_num())].data();
        const float *pd = prior.disparity.ptr<float>(y);
        const uint8_t *pw = prior.weight.ptr<uint8_t>(y);
        for (int x = 0; x < w; ++x)  // read only where the pixel has a weight
            p16[x] = pw[x] ? static_cast<int16_t>(round_to_int(std::clamp(pd[x], 0.0f, 2047.0f) * 16)) : 0;
        const uint64_t *dl = cl.dark.ptr<uint64_t>(y), *dr = cr.dark.ptr<uint64_t>(y);
        uint8_t *out = cost.get() + plane * y;
        row_costs_cloned(ternary, dl, dr, ternary ? cl.bright.ptr<uint64_t>(y) : nullptr,
                         ternary ? cr.bright.ptr<uint64_t>(y) : nullptr, p16, prior.weight.ptr<uint8_t>(y), w, D,
                         slope16, opt.lidar_cap, true, out);
    }

    const Penalties pen{static_cast<uint16_t>(opt.p1), static_cast<uint16_t>(opt.p2), opt.adaptive_p2};
    std::vector<PathRow> scratch(T, PathRow(2, D));
#pragma omp parallel for num_threads(T) schedule(static)
    for (int y = 0; y < h; ++y) {
        PathRow &s = scratch[static_cast<size_t>(omp_get_thread_num())];
        horizontal_paths_of(cost.get() + plane * y, gl.ptr<uint8_t>(y), w, D, pen, true, sum.get() + plane * y, s.at(0),
                            s.at(1));
    }

    const bool diag = opt.paths == 8;
    PathRow zero(1, D);  // read only
    for (int dir : {1, -1}) {
        PathRow pv(w, D), cv_(w, D), pa(w, D), ca(w, D), pb(w, D), cb(w, D);
        const int y_first = dir > 0 ? 0 : h - 1;
#pragma omp parallel num_threads(T)
        {
            PathRow *P[3] = {&pv, &pa, &pb}, *C[3] = {&cv_, &ca, &cb};
            for (int i = 0; i < h; ++i) {
                const int y = dir > 0 ? i : h - 1 - i;
                const uint8_t *img_prev = gl.ptr<uint8_t>(y == y_first ? y : y - dir);
#pragma omp for schedule(static)
                for (int t = 0; t < T; ++t)  // one equal share of the columns per thread
                    column_paths(cost.get() + plane * y, gl.ptr<uint8_t>(y), img_prev, w, D, pen, diag, y == y_first,
                                 zero, *P[0], *C[0], *P[1], *C[1], *P[2], *C[2], sum.get() + plane * y, w * t / T,
                                 w * (t + 1) / T);
                for (int k = 0; k < 3; ++k) std::swap(P[k], C[k]);  // every thread alike, after the barrier
            }
        }
    }
    cost.reset();

    // Winner takes all, uniqueness, left-right check, then the sub-pixel vertex.
    cv::Mat1s disp16(h, w);  // row_winners writes every pixel, the loop below every one again
#pragma omp parallel for num_threads(T) schedule(static)
    for (int y = 0; y < h; ++y) {
        const uint16_t *S = sum.get() + plane * y;
        int16_t *out = disp16.ptr<int16_t>(y);
        std::vector<uint16_t> &scratch = wta_scratch[static_cast<size_t>(omp_get_thread_num())];
        detail::row_winners(S, w, D, opt.uniqueness_ratio, opt.lr_max_diff, true, scratch.data(), out);
        for (int x = 0; x < w; ++x) {
            const int best = out[x];
            if (best < 0) {
                out[x] = -16;
                continue;
            }
            const uint16_t *s = S + static_cast<size_t>(x) * D;
            int v16 = best * 16;
            if (best > 0 && best + 1 < std::min(D, x + 1)) {  // the parabola's vertex through three sums
                const int a = s[best - 1], c = s[best + 1], den = a + c - 2 * s[best];
                if (den > 0) v16 = static_cast<int>(std::lround(16.0 * best + 8.0 * (a - c) / den));
            }
            out[x] = static_cast<int16_t>(std::clamp(v16, 0, 16 * x));
        }
    }
    if (opt.speckle_window > 0) cv::filterSpeckles(disp16, -16, opt.speckle_window, 16 * opt.speckle_range);
    DisparityMap d(h, w);
#pragma omp parallel for num_threads(T) schedule(static)
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) d(y, x) = disp16(y, x) >= 0 ? disp16(y, x) / 16.0f : kInvalidDisparity;
    return d;
}

}  // namespace lidarflow::stereo
