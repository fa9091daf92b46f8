#include "features/dense_sift.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace lidarflow::features {

cv::Mat1f to_gray_float(const cv::Mat &image) {
    require(!image.empty(), ErrorCode::InvalidArgument, "to_gray_float: empty image");
    require(image.depth() == CV_8U, ErrorCode::InvalidArgument, "to_gray_float: image must be 8-bit");
    cv::Mat gray;
    switch (image.channels()) {
    case 1: gray = image; break;
    case 3: cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY); break;
    default:
        throw Error(ErrorCode::InvalidArgument,
                    "to_gray_float: expected 1, 3 or 4 channels, got " + std::to_string(image.channels()));
    }
    cv::Mat1f out;
    gray.convertTo(out, CV_32F, 1.0 / 255.0);
    return out;
}

DescriptorImage compute_dense_sift(const cv::Mat1f &gray, const DenseSiftOptions &options, int threads) {
    require(!gray.empty(), ErrorCode::InvalidArgument, "compute_dense_sift: empty image");
    require(options.dim == 128 || options.dim == 64, ErrorCode::InvalidArgument,
            "compute_dense_sift: dim must be 128 or 64");
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

    // Orientation histogram per pixel: gradient magnitude soft-assigned to the two nearest bins.
    std::vector<float> hist(static_cast<size_t>(h) * row_len, 0.0f);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < h; ++y) {
        const float *up = gray.ptr<float>(std::max(y - 1, 0));
        const float *row = gray.ptr<float>(y);
        const float *down = gray.ptr<float>(std::min(y + 1, h - 1));
        float *hrow = hist.data() + static_cast<size_t>(y) * row_len;
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
            hrow[x * nb + b0] += mag * (1.0f - frac);
            hrow[x * nb + (b0 + 1) % nb] += mag * frac;
        }
    }

    // Bilinear spatial binning = separable triangular filter of half-width cell_size, borders
    // replicated; rows of interleaved bins keep both passes contiguous.
    const int cs = options.cell_size;
    std::vector<float> kern(cs);  // kern[t] for |t| = 0 .. cs-1
    for (int t = 0; t < cs; ++t) kern[t] = static_cast<float>(cs - t) / static_cast<float>(cs);
    std::vector<float> tmp(hist.size());
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < h; ++y) {
        const float *in = hist.data() + static_cast<size_t>(y) * row_len;
        float *o = tmp.data() + static_cast<size_t>(y) * row_len;
        for (int x = 0; x < w; ++x)
            for (int b = 0; b < nb; ++b) {
                float acc = kern[0] * in[x * nb + b];
                for (int t = 1; t < cs; ++t)
                    acc += kern[t] * (in[std::max(x - t, 0) * nb + b] + in[std::min(x + t, w - 1) * nb + b]);
                o[x * nb + b] = acc;
            }
    }
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < h; ++y) {
        float *o = hist.data() + static_cast<size_t>(y) * row_len;
        const float *c = tmp.data() + static_cast<size_t>(y) * row_len;
        for (int i = 0; i < row_len; ++i) o[i] = kern[0] * c[i];
        for (int t = 1; t < cs; ++t) {
            const float *a = tmp.data() + static_cast<size_t>(std::max(y - t, 0)) * row_len;
            const float *b = tmp.data() + static_cast<size_t>(std::min(y + t, h - 1)) * row_len;
            const float k = kern[t];
            for (int i = 0; i < row_len; ++i) o[i] += k * (a[i] + b[i]);
        }
    }

    // Cell centres at (i - 1.5) * cell_size, rounded for odd cell sizes.
    int offs[4];
    for (int i = 0; i < 4; ++i) offs[i] = static_cast<int>(std::lround((i - 1.5) * cs));

    DescriptorImage out;
    out.width = w;
    out.height = h;
    out.dim = options.dim;
    out.data.assign(static_cast<size_t>(w) * h * options.dim, 0);
    const float clip = options.clip, floor_norm = options.norm_floor;
    const int dim = options.dim;

#pragma omp parallel num_threads(threads)
    {
        std::vector<float> v(dim);
#pragma omp for schedule(static)
        for (int y = 0; y < h; ++y) {
            const float *rows[4];
            for (int i = 0; i < 4; ++i)
                rows[i] = hist.data() + static_cast<size_t>(std::clamp(y + offs[i], 0, h - 1)) * row_len;
            for (int x = 0; x < w; ++x) {
                int xs[4];
                for (int i = 0; i < 4; ++i) xs[i] = std::clamp(x + offs[i], 0, w - 1) * nb;
                float *dst_f = v.data();
                for (int cy = 0; cy < 4; ++cy)
                    for (int cx = 0; cx < 4; ++cx) {
                        const float *src = rows[cy] + xs[cx];
                        for (int b = 0; b < nb; ++b) *dst_f++ = src[b];
                    }
                float n2 = 0;
                for (int i = 0; i < dim; ++i) n2 += v[i] * v[i];
                const float norm = std::sqrt(n2);
                // Target length: 1 for normal contrast, shrinking linearly below the floor.
                const float target = std::min(1.0f, norm / floor_norm);
                const float s1 = 1.0f / std::max(norm, floor_norm);
                float m2 = 0;
                for (int i = 0; i < dim; ++i) {
                    const float f = std::min(v[i] * s1, clip);
                    v[i] = f;
                    m2 += f * f;
                }
                const float len = std::sqrt(m2);
                const float s2 = len > 0 ? 512.0f * target / len : 0.0f;
                uint8_t *dst = out.at(x, y);
                for (int i = 0; i < dim; ++i)
                    dst[i] = static_cast<uint8_t>(std::min(255.0f, v[i] * s2 + 0.5f));
            }
        }
    }
    return out;
}

}  // namespace lidarflow::features
