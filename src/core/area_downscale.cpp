// SPDX-License-Identifier: MIT
#include "core/area_downscale.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/cpu_dispatch.hpp"
#include "core/error.hpp"
#include "core/parallel_errors.hpp"
#include "core/threads.hpp"

namespace lidarflow {
namespace {

// Along one axis, the input samples each output sample averages: output i takes samples
// index[start[i] .. start[i + 1]) with their weights, in increasing order. The weights are the
// share of the output cell each sample covers, computed as OpenCV computes them (in double, the
// cell clipped at the image's end, slivers under 1e-3 of a sample dropped), then rounded to float.
struct AreaTaps {
    std::vector<int> start, index;
    std::vector<float> weight;
};

AreaTaps area_taps(int in, int out) {
    // The ratio as cv::resize forms it (the inverse of out / in), so that every weight rounds alike.
    const double scale = 1.0 / (static_cast<double>(out) / in);
    AreaTaps t;
    t.start.reserve(static_cast<size_t>(out) + 1);
    for (int i = 0; i < out; ++i) {
        t.start.push_back(static_cast<int>(t.index.size()));
        const double lo = i * scale, hi = lo + scale;
        const double cell = std::min(scale, in - lo);
        const int last = std::min(static_cast<int>(std::floor(hi)), in - 1);
        const int first = std::min(static_cast<int>(std::ceil(lo)), last);
        const auto add = [&t](int sample, double share) {
            t.index.push_back(sample);
            t.weight.push_back(static_cast<float>(share));
        };
        if (first - lo > 1e-3) add(first - 1, (first - lo) / cell);
        for (int s = first; s < last; ++s) add(s, 1.0 / cell);
        if (hi - last > 1e-3) add(last, std::min(std::min(hi - last, 1.0), cell) / cell);
    }
    t.start.push_back(static_cast<int>(t.index.size()));
    return t;
}

// The x sums as a fixed number of taps per output value (taps * n entries, tap-major): the
// input value's position in the row (cn values per pixel) and its weight. An output pixel with
// fewer taps gets weight-0 ones on its last sample: adding +0 leaves a non-negative sum as it was,
// so every sum is the same IEEE sequence as with its own taps, and the loop below vectorises.
struct RowTaps {
    int taps = 0, n = 0;
    std::vector<int> at;
    std::vector<float> weight;
};

RowTaps row_taps(const AreaTaps &x, int width, int cn) {
    RowTaps r;
    for (int i = 0; i < width; ++i) r.taps = std::max(r.taps, x.start[i + 1] - x.start[i]);
    r.n = width * cn;
    r.at.assign(static_cast<size_t>(r.taps) * r.n, 0);
    r.weight.assign(static_cast<size_t>(r.taps) * r.n, 0.0f);
    for (int i = 0; i < width; ++i)
        for (int j = 0; j < r.taps; ++j) {
            const int k = std::min(x.start[i] + j, x.start[i + 1] - 1);
            const bool real = x.start[i] + j < x.start[i + 1];
            for (int c = 0; c < cn; ++c) {
                const size_t e = static_cast<size_t>(j) * r.n + static_cast<size_t>(i) * cn + c;
                r.at[e] = x.index[k] * cn + c;
                r.weight[e] = real ? x.weight[k] : 0.0f;
            }
        }
    return r;
}

// One input row (as floats) summed along x into out: each value its taps' products added in order.
LIDARFLOW_AVX2_CLONES void sum_row(const float *__restrict row, const int *__restrict at,
                                   const float *__restrict weight, int taps, int n, float *__restrict out) {
    for (int e = 0; e < n; ++e) out[e] = row[at[e]] * weight[e];
    for (int j = 1; j < taps; ++j) {
        const int *a = at + static_cast<size_t>(j) * n;
        const float *w = weight + static_cast<size_t>(j) * n;
        for (int e = 0; e < n; ++e) out[e] = out[e] + row[a[e]] * w[e];
    }
}

LIDARFLOW_AVX2_CLONES void to_float(const uint8_t *__restrict in, int n, float *__restrict out) {
    for (int i = 0; i < n; ++i) out[i] = static_cast<float>(in[i]);
}

// cv::saturate_cast<uchar> of each value: rounded half to even (the FPU's default mode, as
// cvRound), then saturated. Four at a time where SSE2 is there (libm's lrintf is a call each).
void round_to_bytes(const float *in, int n, uint8_t *out) {
    int i = 0;
#if defined(__SSE2__)
    for (; i + 16 <= n; i += 16) {
        const __m128i a = _mm_cvtps_epi32(_mm_loadu_ps(in + i)), b = _mm_cvtps_epi32(_mm_loadu_ps(in + i + 4));
        const __m128i c = _mm_cvtps_epi32(_mm_loadu_ps(in + i + 8)), d = _mm_cvtps_epi32(_mm_loadu_ps(in + i + 12));
        _mm_storeu_si128(reinterpret_cast<__m128i *>(out + i),
                         _mm_packus_epi16(_mm_packs_epi32(a, b), _mm_packs_epi32(c, d)));
    }
#endif
    for (; i < n; ++i) out[i] = static_cast<uint8_t>(std::clamp(static_cast<int>(std::lrintf(in[i])), 0, 255));
}

// Output rows [y0, y1): each the weighted sum of its input rows' x sums, in the rows' order,
// rounded half to even and saturated as cv::saturate_cast<uchar> does. An input row shared by
// two output rows is summed along x once.
void downscale_rows(const cv::Mat &src, cv::Mat &dst, const RowTaps &x, const AreaTaps &y, int y0, int y1) {
    const int n = x.n, in_n = src.cols * src.channels();
    // An output row's input rows follow the previous one's: only the last x sum can serve again.
    std::vector<float> current(static_cast<size_t>(n)), sum(static_cast<size_t>(n)), in(static_cast<size_t>(in_n));
    int current_row = -1;
    for (int oy = y0; oy < y1; ++oy) {
        for (int k = y.start[oy]; k < y.start[oy + 1]; ++k) {
            const int iy = y.index[k];
            if (iy != current_row) {
                to_float(src.ptr<uint8_t>(iy), in_n, in.data());
                sum_row(in.data(), x.at.data(), x.weight.data(), x.taps, n, current.data());
                current_row = iy;
            }
            const float beta = y.weight[k];
            if (k == y.start[oy])
                for (int i = 0; i < n; ++i) sum[i] = beta * current[i];
            else
                for (int i = 0; i < n; ++i) sum[i] = sum[i] + beta * current[i];
        }
        round_to_bytes(sum.data(), n, dst.ptr<uint8_t>(oy));
    }
}

}  // namespace

void area_downscale(const cv::Mat &src, cv::Mat &dst, cv::Size size, int threads) {
    require(!src.empty(), ErrorCode::InvalidArgument, "area_downscale: empty image");
    require(size.width >= 1 && size.height >= 1, ErrorCode::InvalidArgument, "area_downscale: size below 1x1");
    require(threads >= 1, ErrorCode::InvalidArgument, "area_downscale: threads must be >= 1");
    const double scale_x = 1.0 / (static_cast<double>(size.width) / src.cols);
    const double scale_y = 1.0 / (static_cast<double>(size.height) / src.rows);
    const bool integer = std::abs(scale_x - std::lround(scale_x)) < DBL_EPSILON &&
                         std::abs(scale_y - std::lround(scale_y)) < DBL_EPSILON;
    if (src.depth() != CV_8U || src.channels() > 4 || scale_x < 1.0 || scale_y < 1.0 || integer) {
        cv::resize(src, dst, size, 0, 0, cv::INTER_AREA);
        return;
    }
    const RowTaps x = row_taps(area_taps(src.cols, size.width), size.width, src.channels());
    const AreaTaps y = area_taps(src.rows, size.height);
    cv::Mat out(size, src.type());
    ParallelErrors errors;
    const int parts = std::max(1, std::min(threads, size.height / 8));
    for_each_band(size.height, parts,
                  [&](int, int y0, int y1) { errors.run([&] { downscale_rows(src, out, x, y, y0, y1); }); });
    errors.rethrow_if_any();
    dst = out;
}

}  // namespace lidarflow
