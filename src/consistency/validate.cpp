// SPDX-License-Identifier: MIT
#include "consistency/validate.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/error.hpp"

namespace lidarflow::consistency::detail {

void check_size(const cv::Mat &m, int rows, int cols, const std::string &name) {
    require(m.rows == rows && m.cols == cols, ErrorCode::SizeMismatch,
            "consistency: " + name + " is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) +
                ", expected " + std::to_string(cols) + "x" + std::to_string(rows));
}

void check_field(const SceneFlowField &f, const std::string &name) {
    require(!f.u.empty(), ErrorCode::InvalidArgument, "consistency: " + name + " field is empty");
    const int h = f.u.rows, w = f.u.cols;
    check_size(f.v, h, w, name + ".v");
    check_size(f.d0, h, w, name + ".d0");
    check_size(f.d1, h, w, name + ".d1");
    check_size(f.valid, h, w, name + ".valid");
    if (!f.confidence.empty()) check_size(f.confidence, h, w, name + ".confidence");
    // Stage 2-3 checks every field it is handed (nine scans per frame): a branch-free pass that
    // the compiler vectorises answers "all finite" (~20 ms per KITTI frame as the loop below);
    // the loop only runs to name the first bad pixel.
    const auto nonfinite = [](const float *p, int x) {
        uint32_t bits;
        std::memcpy(&bits, p + x, sizeof bits);
        return static_cast<uint32_t>((bits & 0x7f800000u) == 0x7f800000u);
    };
    uint32_t bad = 0;
    for (int y = 0; y < h; ++y) {
        const uint8_t *valid = f.valid[y];
        const float *u = f.u[y], *v = f.v[y], *d0 = f.d0[y], *d1 = f.d1[y];
        const float *c = f.confidence.empty() ? d1 : f.confidence[y];
        for (int x = 0; x < w; ++x)
            bad |= (nonfinite(u, x) | nonfinite(v, x) | nonfinite(d0, x) | nonfinite(d1, x) | nonfinite(c, x)) &
                   static_cast<uint32_t>(valid[x] != 0);
    }
    if (!bad) return;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!f.valid(y, x)) continue;
            const bool finite = std::isfinite(f.u(y, x)) && std::isfinite(f.v(y, x)) &&
                                std::isfinite(f.d0(y, x)) && std::isfinite(f.d1(y, x)) &&
                                std::isfinite(confidence_at(f, y, x));
            require(finite, ErrorCode::InvalidArgument, [&] {
                return "consistency: " + name + " has a non-finite value at valid pixel (" + std::to_string(x) +
                       ", " + std::to_string(y) + ")";
            });
        }
}

namespace {
void check_positive(float v, const char *what) {
    require(std::isfinite(v) && v > 0.0f, ErrorCode::InvalidArgument,
            std::string("consistency: option ") + what + " must be finite and > 0");
}
}  // namespace

void check_options(const ConsistencyOptions &opt) {
    require(opt.threads >= 1 && opt.threads <= 1024, ErrorCode::InvalidArgument,
            "consistency: option threads must be in [1, 1024]");
    check_positive(opt.sgm_max_diff, "sgm_max_diff");
    check_positive(opt.fb_max_flow, "fb_max_flow");
    check_positive(opt.fb_max_d0, "fb_max_d0");
    check_positive(opt.fb_max_d1, "fb_max_d1");
    check_positive(opt.cluster_max_flow_step, "cluster_max_flow_step");
    check_positive(opt.cluster_max_disp_step, "cluster_max_disp_step");
    require(opt.cluster_min_size >= 1, ErrorCode::InvalidArgument, "consistency: cluster_min_size must be >= 1");
    require(opt.fb_search_radius >= 0 && opt.fb_search_radius <= 8, ErrorCode::InvalidArgument,
            "consistency: fb_search_radius must be in [0, 8]");
    require(opt.sparsify_support >= 1 && opt.sparsify_support % 2 == 1, ErrorCode::InvalidArgument,
            "consistency: sparsify_support must be odd and >= 1");
    require(std::isfinite(opt.sparsify_missing_error) && opt.sparsify_missing_error >= 0, ErrorCode::InvalidArgument,
            "consistency: sparsify_missing_error must be finite and >= 0");
    require(opt.grid_step >= 1, ErrorCode::InvalidArgument, "consistency: grid_step must be >= 1");
    require(opt.sparsify_block >= 1, ErrorCode::InvalidArgument, "consistency: sparsify_block must be >= 1");
    require(opt.support_window >= 1 && opt.support_window % 2 == 1, ErrorCode::InvalidArgument,
            "consistency: support_window must be odd and >= 1");
    const SgmOptions &s = opt.sgm;
    require(s.num_disparities >= 16 && s.num_disparities % 16 == 0, ErrorCode::InvalidArgument,
            "consistency: sgm.num_disparities must be a positive multiple of 16");
    require(s.block_size >= 1 && s.block_size % 2 == 1, ErrorCode::InvalidArgument,
            "consistency: sgm.block_size must be odd and >= 1");
    require(s.uniqueness_ratio >= 0 && s.speckle_window >= 0 && s.speckle_range >= 0, ErrorCode::InvalidArgument,
            "consistency: sgm uniqueness_ratio, speckle_window and speckle_range must be >= 0");
}

}  // namespace lidarflow::consistency::detail
