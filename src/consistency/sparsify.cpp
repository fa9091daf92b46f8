// SPDX-License-Identifier: MIT
#include "consistency/sparsify.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "consistency/steps.hpp"
#include "consistency/validate.hpp"
#include "core/error.hpp"

namespace lidarflow::consistency {

SceneFlowField detail::sparsify(const SceneFlowField &field, const cv::Mat1f &error, const LidarReference &lidar,
                                const CheckedOptions &checked) {
    const ConsistencyOptions &opt = checked.get();
    detail::check_field(field, "sparsified");
    const int h = field.height(), w = field.width();
    detail::check_size(error, h, w, "consistency error");
    detail::check_size(lidar.is_lidar, h, w, "LiDAR mask");

    const int b = opt.sparsify_block;
    // Neighbourhood consistency: mean error over the support window, missing matches (and
    // matches whose round trip could not be made) at the penalty. LiDAR pixels are not ranked.
    cv::Mat1f score(h, w);
    int nan_rows = 0;
    const int threads = std::max(1, opt.threads);
#pragma omp parallel for num_threads(threads) schedule(static) reduction(+ : nan_rows)
    for (int y = 0; y < h; ++y) {
        bool nan = false;
        for (int x = 0; x < w; ++x) {
            const float e = error(y, x);
            nan |= std::isnan(e);
            // Ranked by its own error, a match keeps it (+inf last); averaged, an unmeasured
            // round trip counts like a missing neighbour.
            score(y, x) = !field.valid(y, x) ? opt.sparsify_missing_error
                          : opt.sparsify_support == 1 || std::isfinite(e) ? e
                                                                          : opt.sparsify_missing_error;
        }
        nan_rows += nan;
    }
    require(nan_rows == 0, ErrorCode::InvalidArgument, "sparsify: NaN in the consistency error");
    if (opt.sparsify_support > 1)
        cv::blur(score, score, {opt.sparsify_support, opt.sparsify_support}, {-1, -1}, cv::BORDER_REPLICATE);
    SceneFlowField out = SceneFlowField::uninitialized(w, h);  // each row cleared where it is filled
    // Blocks write only their own pixels: a row of blocks per iteration.
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int by = 0; by < h; by += b) {
        for (int y = by; y < std::min(by + b, h); ++y) out.clear_row(y);
        for (int bx = 0; bx < w; bx += b) {
            int best_x = -1, best_y = -1;
            float best_err = 0, best_conf = 0;
            for (int y = by; y < std::min(by + b, h); ++y)
                for (int x = bx; x < std::min(bx + b, w); ++x) {
                    if (!field.valid(y, x)) continue;
                    if (lidar.is_lidar(y, x)) {
                        detail::keep_match(out, field, y, x);
                        continue;
                    }
                    const float e = score(y, x), c = detail::confidence_at(field, y, x);
                    // Strict comparisons keep the first pixel in raster order on full ties.
                    if (best_x < 0 || e < best_err || (e == best_err && c > best_conf)) {
                        best_x = x;
                        best_y = y;
                        best_err = e;
                        best_conf = c;
                    }
                }
            if (best_x >= 0) detail::keep_match(out, field, best_y, best_x);
        }
    }
    return out;
}

SceneFlowField sparsify(const SceneFlowField &field, const cv::Mat1f &error, const LidarReference &lidar,
                        const ConsistencyOptions &opt) {
    return detail::sparsify(field, error, lidar, detail::CheckedOptions(opt));
}

}  // namespace lidarflow::consistency
