// SPDX-License-Identifier: MIT
#include "features/dense_sift.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/cpu_dispatch.hpp"
#include "core/error.hpp"
#include "core/gray.hpp"
#include "core/parallel_errors.hpp"

namespace lidarflow::features {

namespace {
// 4-bit levels of a full-contrast descriptor: 180 * (q / 15)^2, rounded. Why these: a third of
// all values are 0 and the density falls steeply (median ~10, 97th percentile ~130 on KITTI
// and on the synthetic scenes), so levels spaced on the square root put the precision where
// the values are: a quarter of the squared error of even levels, and fitted (Lloyd-Max) levels
// were no better in final SF (docs/experiments/speed-stage1.md, 3f7256f).
constexpr uint8_t kLevels4[16] = {0, 1, 3, 7, 13, 20, 29, 39, 51, 65, 80, 97, 115, 135, 157, 180};

// 8-bit value -> code of its nearest level (the lower one on a tie).
struct Code4 {
    uint8_t q[256] = {};
    Code4() {
        for (int v = 0, k = 0; v < 256; ++v) {
            while (k < 15 && std::abs(kLevels4[k + 1] - v) < std::abs(kLevels4[k] - v)) ++k;
            q[v] = static_cast<uint8_t>(k);
        }
    }
};
const Code4 kCode4;

}  // namespace

// Row k: round(kLevels4[q] * k / kContrastSteps), the decoded values of contrast index k.
alignas(16) uint8_t kPackedLevels[kContrastSteps + 1][16];
namespace {
const bool kPackedLevelsReady = [] {
    for (int k = 0; k <= kContrastSteps; ++k)
        for (int q = 0; q < 16; ++q)
            kPackedLevels[k][q] = static_cast<uint8_t>((kLevels4[q] * k * 2 + kContrastSteps) / (2 * kContrastSteps));
    return true;
}();
}  // namespace

cv::Mat1f to_gray_float(const cv::Mat &image) {
    cv::Mat1f out;
    gray8(image).convertTo(out, CV_32F, 1.0 / 255.0);
    return out;
}

namespace {

// Horizontal triangular filter of one row of interleaved NB-bin histograms (borders replicated).
template <int NB>
void blur_row(const float *in, float *o, int w, const float *kern, int cs) {
    for (int x = 0; x < w; ++x) {
        float acc[NB];
        for (int b = 0; b < NB; ++b) acc[b] = kern[0] * in[x * NB + b];
        for (int t = 1; t < cs; ++t) {
            const float *l = in + std::max(x - t, 0) * NB, *r = in + std::min(x + t, w - 1) * NB;
            for (int b = 0; b < NB; ++b) acc[b] += kern[t] * (l[b] + r[b]);
        }
        for (int b = 0; b < NB; ++b) o[x * NB + b] = acc[b];
    }
}

struct RowParams {
    int w = 0;
    int offs[4] = {};
    float clip = 0, floor_norm = 0;
};

// One row of descriptors: gather the 4x4 cells of NB bins, normalise with the contrast floor,
// clip, renormalise to length 512 * target and quantise. Fixed sizes and 8 explicit partial
// sums let the compiler vectorise every loop (the sums are per lane, so no -ffast-math).
template <int NB, int BITS>
__attribute__((always_inline)) inline void describe_row_impl(const float *const rows[4], const RowParams &p,
                                                             uint8_t *dst, uint8_t *contrast) {
    constexpr int D = 16 * NB;
    alignas(32) float v[D];
    const int w = p.w;
    for (int x = 0; x < w; ++x, dst += D * BITS / 8) {
        for (int cx = 0; cx < 4; ++cx) {
            const int sx = std::clamp(x + p.offs[cx], 0, w - 1) * NB;
            for (int cy = 0; cy < 4; ++cy) std::memcpy(v + (cy * 4 + cx) * NB, rows[cy] + sx, NB * sizeof(float));
        }
        float acc[8] = {};
        for (int i = 0; i < D; i += 8)
            for (int j = 0; j < 8; ++j) acc[j] += v[i + j] * v[i + j];
        const float norm = std::sqrt(((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])));
        // Target length: 1 for normal contrast, shrinking linearly below the floor.
        const float target = std::min(1.0f, norm / p.floor_norm);
        const float s1 = 1.0f / std::max(norm, p.floor_norm);
        float acc2[8] = {};
        for (int i = 0; i < D; i += 8)
            for (int j = 0; j < 8; ++j) {
                const float f = std::min(v[i + j] * s1, p.clip);
                v[i + j] = f;
                acc2[j] += f * f;
            }
        const float len =
            std::sqrt(((acc2[0] + acc2[1]) + (acc2[2] + acc2[3])) + ((acc2[4] + acc2[5]) + (acc2[6] + acc2[7])));
        const float s2 = len > 0 ? 512.0f * target / len : 0.0f;
        if constexpr (BITS == 8) {
            for (int i = 0; i < D; ++i) dst[i] = static_cast<uint8_t>(static_cast<int>(std::min(255.0f, v[i] * s2 + 0.5f)));
        } else {
            // The full-contrast descriptor's 8-bit values, then their nearest levels (kCode4);
            // the contrast goes into its own byte.
            const float s1 = len > 0 ? 512.0f / len : 0.0f;
            contrast[x] = static_cast<uint8_t>(static_cast<int>(target * kContrastSteps + 0.5f));
            alignas(32) uint8_t b[D];
            for (int i = 0; i < D; ++i) b[i] = static_cast<uint8_t>(static_cast<int>(std::min(255.0f, v[i] * s1 + 0.5f)));
            for (int i = 0; i < D / 2; ++i) dst[i] = static_cast<uint8_t>(kCode4.q[b[i]] | kCode4.q[b[i + D / 2]] << 4);
        }
    }
}

// AVX2 and baseline versions (core/cpu_dispatch.hpp).
LIDARFLOW_AVX2_CLONES void describe_row8(const float *const rows[4], const RowParams &p, uint8_t *dst, uint8_t *contrast) {
    describe_row_impl<8, 8>(rows, p, dst, contrast);
}
LIDARFLOW_AVX2_CLONES void describe_row4(const float *const rows[4], const RowParams &p, uint8_t *dst, uint8_t *contrast) {
    describe_row_impl<4, 8>(rows, p, dst, contrast);
}
LIDARFLOW_AVX2_CLONES void describe_row8_packed(const float *const rows[4], const RowParams &p, uint8_t *dst,
                                         uint8_t *contrast) {
    describe_row_impl<8, 4>(rows, p, dst, contrast);
}
LIDARFLOW_AVX2_CLONES void describe_row4_packed(const float *const rows[4], const RowParams &p, uint8_t *dst,
                                         uint8_t *contrast) {
    describe_row_impl<4, 4>(rows, p, dst, contrast);
}

}  // namespace

DescriptorImage compute_dense_sift(const cv::Mat1f &gray, const DenseSiftOptions &options, int threads) {
    DescriptorImage out;
    compute_dense_sift(gray, options, threads, out);
    return out;
}

void compute_dense_sift(const cv::Mat1f &gray, const DenseSiftOptions &options, int threads,
                        DescriptorImage &out) {
    compute_dense_sift(gray, options, threads, out, nullptr);
}

namespace {

// The descriptors' bytes; bits 4 adds a contrast byte per pixel after them.
size_t descriptor_data_bytes(int width, int height, const DenseSiftOptions &options) {
    return static_cast<size_t>(width) * static_cast<size_t>(height) * static_cast<size_t>(options.dim * options.bits / 8);
}

}  // namespace

size_t descriptor_bytes(int width, int height, const DenseSiftOptions &options) {
    const size_t contrast = options.bits == 4 ? static_cast<size_t>(width) * static_cast<size_t>(height) : 0;
    return descriptor_data_bytes(width, height, options) + contrast;
}

void compute_dense_sift(const cv::Mat1f &gray, const DenseSiftOptions &options, int threads,
                        DescriptorImage &out, uint8_t *memory) {
    require(!gray.empty(), ErrorCode::InvalidArgument, "compute_dense_sift: empty image");
    require(options.dim == 128 || options.dim == 64, ErrorCode::InvalidArgument,
            "compute_dense_sift: dim must be 128 or 64");
    require(options.bits == 8 || options.bits == 4, ErrorCode::InvalidArgument,
            "compute_dense_sift: bits must be 8 or 4");
    require(options.cell_size >= 1 && options.cell_size <= 16, ErrorCode::InvalidArgument,
            "compute_dense_sift: cell_size must be in [1, 16]");
    require(std::isfinite(options.clip) && options.clip > 0.0f && std::isfinite(options.norm_floor) &&
                options.norm_floor > 0.0f,
            ErrorCode::InvalidArgument, "compute_dense_sift: clip and norm_floor must be positive");
    require(threads >= 1, ErrorCode::InvalidArgument, "compute_dense_sift: threads must be >= 1");

    const int w = gray.cols, h = gray.rows;
    const int nb = options.dim / 16;  // orientation bins
    // 128: signed orientations over 2*pi; 64: unsigned over pi (opposite gradients share a bin).
    const float period = nb == 8 ? 2.0f * static_cast<float>(CV_PI) : static_cast<float>(CV_PI);
    const float bins_per_rad = static_cast<float>(nb) / period;
    const int row_len = w * nb;  // interleaved: the nb bins of a pixel are contiguous

    // Bilinear spatial binning = separable triangular filter of half-width cell_size, borders
    // replicated; rows of interleaved bins keep both passes contiguous.
    const int cs = options.cell_size;
    std::vector<float> kern(cs);  // kern[t] for |t| = 0 .. cs-1
    for (int t = 0; t < cs; ++t) kern[t] = static_cast<float>(cs - t) / static_cast<float>(cs);

    // Cell centres at (i - 1.5) * cell_size, rounded for odd cell sizes.
    RowParams rp;
    rp.w = w;
    for (int i = 0; i < 4; ++i) rp.offs[i] = static_cast<int>(std::lround((i - 1.5) * cs));
    rp.clip = options.clip;
    rp.floor_norm = options.norm_floor;

    // clear() first: a resize that must grow would otherwise copy the old descriptors over.
    // The image is empty until the storage is there, so a bad_alloc leaves it consistent.
    out.width = out.height = out.dim = 0;
    out.lent = out.lent_contrast = nullptr;
    out.data.clear();
    out.contrast.clear();
    const size_t data_bytes = descriptor_data_bytes(w, h, options);
    if (memory) {
        decltype(out.data)().swap(out.data);
        decltype(out.contrast)().swap(out.contrast);
        out.lent = memory;
        if (options.bits == 4) out.lent_contrast = memory + data_bytes;
    } else {
        out.data.resize(data_bytes);
        if (options.bits == 4) out.contrast.resize(static_cast<size_t>(w) * h);
    }
    out.width = w;
    out.height = h;
    out.dim = options.dim;
    out.bits = options.bits;

    // Bands of output rows, each computed from its own slice of histogram rows (plus the halo
    // the two filters and the cell offsets need) in per-thread scratch: the scratch stays a few
    // MB and cache-resident instead of two whole-image float arrays (2 x 15 MB per KITTI image,
    // fresh pages on every call). The halo rows are computed twice (~12 % more histogram work
    // at 64 rows); every value is computed exactly as on the whole image.
    constexpr int kBand = 64;
    const int reach = std::max(std::abs(rp.offs[0]), std::abs(rp.offs[3]));  // cell offsets
    const int halo = reach + (cs - 1);                                          // + vertical blur
    const int bands = (h + kBand - 1) / kBand;
    const size_t scratch_rows = static_cast<size_t>(std::min(h, kBand + 2 * halo));
    ParallelErrors errors;
#pragma omp parallel num_threads(threads)
    {
        std::unique_ptr<float[]> hist, tmp;  // rows [ha, hb) of the histogram / its blurs
        errors.run([&] {
            hist.reset(new float[scratch_rows * row_len]);
            tmp.reset(new float[scratch_rows * row_len]);
        });
#pragma omp for schedule(dynamic, 1)
        for (int band = 0; band < bands; ++band)
            errors.run([&] {
                const int y0 = band * kBand, y1 = std::min(h, y0 + kBand);
                const int ba = std::max(0, y0 - reach), bb = std::min(h, y1 + reach);  // blurred rows
                const int ha = std::max(0, ba - (cs - 1)), hb = std::min(h, bb + (cs - 1));
                const auto hrow = [&](float *buf, int y) { return buf + static_cast<size_t>(y - ha) * row_len; };
                // Orientation histogram per pixel: gradient magnitude soft-assigned to the two
                // nearest bins.
                for (int y = ha; y < hb; ++y) {
                    const float *up = gray.ptr<float>(std::max(y - 1, 0));
                    const float *row = gray.ptr<float>(y);
                    const float *down = gray.ptr<float>(std::min(y + 1, h - 1));
                    float *o = hrow(hist.get(), y);
                    std::fill(o, o + row_len, 0.0f);
                    for (int x = 0; x < w; ++x) {
                        const float gx = 0.5f * (row[std::min(x + 1, w - 1)] - row[std::max(x - 1, 0)]);
                        const float gy = 0.5f * (down[x] - up[x]);
                        const float mag = std::sqrt(gx * gx + gy * gy);
                        if (mag <= 0.0f) continue;
                        float theta = std::atan2(gy, gx);
                        if (theta < 0) theta += 2.0f * static_cast<float>(CV_PI);
                        float b = theta * bins_per_rad;
                        int b0 = static_cast<int>(b);
                        const float frac = b - static_cast<float>(b0);
                        b0 %= nb;
                        o[x * nb + b0] += mag * (1.0f - frac);
                        o[x * nb + (b0 + 1) % nb] += mag * frac;
                    }
                }
                for (int y = ha; y < hb; ++y) {
                    if (nb == 8)
                        blur_row<8>(hrow(hist.get(), y), hrow(tmp.get(), y), w, kern.data(), cs);
                    else
                        blur_row<4>(hrow(hist.get(), y), hrow(tmp.get(), y), w, kern.data(), cs);
                }
                // Vertical pass back into `hist` (its horizontal input is no longer needed).
                for (int y = ba; y < bb; ++y) {
                    float *o = hrow(hist.get(), y);
                    const float *c = hrow(tmp.get(), y);
                    for (int i = 0; i < row_len; ++i) o[i] = kern[0] * c[i];
                    for (int t = 1; t < cs; ++t) {
                        const float *a = hrow(tmp.get(), std::max(y - t, 0));
                        const float *b = hrow(tmp.get(), std::min(y + t, h - 1));
                        const float k = kern[t];
                        for (int i = 0; i < row_len; ++i) o[i] += k * (a[i] + b[i]);
                    }
                }
                for (int y = y0; y < y1; ++y) {
                    const float *rows[4];
                    for (int i = 0; i < 4; ++i) rows[i] = hrow(hist.get(), std::clamp(y + rp.offs[i], 0, h - 1));
                    uint8_t *contrast = options.bits == 8 ? nullptr : out.contrast_bytes() + static_cast<size_t>(y) * w;
                    if (options.bits == 8)
                        (nb == 8 ? describe_row8 : describe_row4)(rows, rp, out.at(0, y), contrast);
                    else
                        (nb == 8 ? describe_row8_packed : describe_row4_packed)(rows, rp, out.at(0, y), contrast);
                }
            });
    }
    errors.rethrow_if_any();
}

}  // namespace lidarflow::features
