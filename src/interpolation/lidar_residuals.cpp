// SPDX-License-Identifier: MIT
#include "interpolation/lidar_residuals.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/bucket_lists.hpp"
#include "core/error.hpp"

namespace lidarflow::interpolation {

cv::Mat1f lidar_residual_correction(const cv::Mat1i &model_of, const std::vector<cv::Point> &points,
                                    const std::vector<float> &residuals, float radius, float prior_weight,
                                    int threads) {
    require(points.size() == residuals.size(), ErrorCode::InvalidArgument,
            "lidar residuals: one residual per point");
    require(std::isfinite(radius) && radius >= 0.0f && radius <= 64.0f, ErrorCode::InvalidArgument,
            "lidar residuals: radius must be in [0, 64]");
    require(std::isfinite(prior_weight) && prior_weight > 0.0f, ErrorCode::InvalidArgument,
            "lidar residuals: prior_weight must be > 0");
    require(threads >= 1 && threads <= 1024, ErrorCode::InvalidArgument, "lidar residuals: threads must be in [1, 1024]");
    const int w = model_of.cols, h = model_of.rows;
    cv::Mat1f sum(h, w, 0.0f), weight(h, w, 0.0f);
    if (radius == 0.0f) return sum;
    for (const cv::Point &p : points)
        require(p.x >= 0 && p.y >= 0 && p.x < w && p.y < h, ErrorCode::InvalidArgument,
                "lidar residuals: point outside the model map");
    const float r2 = radius * radius;
    const int reach = static_cast<int>(std::ceil(radius));
    // Each point spreads over its window: ~(2 * reach + 1)^2 pixels a point. Bands of rows, each
    // with the list of the points that reach it in their order, go to the threads as they free
    // up (a scan fills the lower rows only): every pixel adds its terms in point order whatever
    // the thread count.
    constexpr int kBandRows = 8;
    const int bands = (h + kBandRows - 1) / kBandRows;
    const BucketLists reaching = bucket_lists(points.size(), bands, [&](size_t i, int &b0, int &b1) {
        b0 = std::max(0, points[i].y - reach) / kBandRows;
        b1 = std::min(h - 1, points[i].y + reach) / kBandRows;
    });
#pragma omp parallel for num_threads(std::max(1, std::min(threads, bands))) schedule(dynamic, 1)
    for (int b = 0; b < bands; ++b) {
        const int y0 = b * kBandRows, y1 = std::min(h, y0 + kBandRows);
        for (size_t k = reaching.begin(b); k < reaching.end(b); ++k) {
            const size_t i = reaching.items[k];
            const cv::Point p = points[i];
            const int ya = std::max(y0, p.y - reach), yb = std::min(y1 - 1, p.y + reach);
            const int model = model_of(p);
            const float r = residuals[i];
            for (int y = ya; y <= yb; ++y) {
                const int *mr = model_of[y];
                float *sr = sum[y], *wr = weight[y];
                const float dy = static_cast<float>(y - p.y);
                for (int x = std::max(0, p.x - reach); x <= std::min(w - 1, p.x + reach); ++x) {
                    const float dx = static_cast<float>(x - p.x), d2 = dx * dx + dy * dy;
                    if (d2 >= r2 || mr[x] != model) continue;
                    const float q = 1.0f - d2 / r2, wt = q * q;
                    sr[x] += wt * r;
                    wr[x] += wt;
                }
            }
        }
        for (int y = y0; y < y1; ++y) {
            float *sr = sum[y];
            const float *wr = weight[y];
            for (int x = 0; x < w; ++x) sr[x] = wr[x] > 0.0f ? sr[x] / (wr[x] + prior_weight) : 0.0f;
        }
    }
    return sum;
}

}  // namespace lidarflow::interpolation
