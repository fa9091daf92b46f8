// SPDX-License-Identifier: MIT
#include "matching/matching_options.hpp"

#include <cmath>

#include "core/error.hpp"

namespace lidarflow::matching {

const char *match_method_name(MatchMethod m) {
    return m == MatchMethod::Decoupled ? "decoupled" : "patchmatch";
}

MatchMethod parse_match_method(const std::string &name) {
    for (MatchMethod m : {MatchMethod::PatchMatch, MatchMethod::Decoupled})
        if (name == match_method_name(m)) return m;
    throw Error(ErrorCode::InvalidArgument, "unknown matching method '" + name + "' (patchmatch, decoupled)");
}

const char *variant_name(MatchVariant v) {
    switch (v) {
    case MatchVariant::ImageOnly: return "im-only";
    case MatchVariant::ImLidar: return "im+LiDAR";
    case MatchVariant::ImLidarWin: return "im+LiDAR+win";
    case MatchVariant::ImLidarWinConst1: return "im+LiDAR+win+const1";
    case MatchVariant::Full: return "im+LiDAR+win+const1+const2";
    }
    return "?";
}

MatchingOptions MatchingOptions::for_variant(MatchVariant v) { return MatchingOptions{}.with_variant(v); }

MatchingOptions MatchingOptions::with_variant(MatchVariant v) const {
    MatchingOptions o = *this;
    o.use_lidar = v != MatchVariant::ImageOnly;
    o.support_window = v == MatchVariant::ImLidarWin || v == MatchVariant::ImLidarWinConst1 ||
                       v == MatchVariant::Full;
    o.const1 = v == MatchVariant::ImLidarWinConst1 || v == MatchVariant::Full;
    o.const2 = v == MatchVariant::Full;
    return o;
}

void MatchingOptions::validate() const {
    auto check = [](bool ok, const char *what) {
        require(ok, ErrorCode::InvalidArgument, std::string("MatchingOptions: ") + what);
    };
    check(min_coarsest_height >= 8, "min_coarsest_height must be >= 8");
    check(max_levels >= 1 && max_levels <= 10, "max_levels must be in [1, 10]");
    check(grid_step >= 1 && grid_step <= 32, "grid_step must be in [1, 32]");
    check(backward_grid_step >= 0 && backward_grid_step <= 32, "backward_grid_step must be in [0, 32]");
    check(thin_from_level >= 1 && thin_from_level <= 100, "thin_from_level must be in [1, 100]");
    check(min_level_seeds >= 1, "min_level_seeds must be >= 1");
    check(iterations >= 1 && iterations <= 100, "iterations must be in [1, 100]");
    check(std::isfinite(stop_ratio) && stop_ratio >= 0.0f && stop_ratio <= 1.0f,
          "stop_ratio must be in [0, 1]");
    check(std::isfinite(settle_ratio) && settle_ratio >= 0.0f && settle_ratio <= 100.0f,
          "settle_ratio must be in [0, 100]");
    check(std::isfinite(max_flow) && max_flow >= 1.0f, "max_flow must be >= 1");
    check(std::isfinite(max_disparity) && max_disparity >= 1.0f, "max_disparity must be >= 1");
    check(sift.dim == 128 || sift.dim == 64, "sift.dim must be 128 or 64");
    check(sift.bits == 8 || sift.bits == 4, "sift.bits must be 8 or 4");
    check(sift.cell_size >= 1 && sift.cell_size <= 16, "sift.cell_size must be in [1, 16]");
    check(std::isfinite(sift.clip) && sift.clip > 0, "sift.clip must be > 0");
    check(std::isfinite(sift.norm_floor) && sift.norm_floor > 0, "sift.norm_floor must be > 0");
    check(patch_radius >= 0 && patch_radius <= 16, "patch_radius must be in [0, 16]");
    check(patch_step >= 1, "patch_step must be >= 1");
    check(std::isfinite(out_of_image_penalty) && out_of_image_penalty >= 0,
          "out_of_image_penalty must be >= 0");
    check(window_size >= 1 && window_size % 2 == 1 && window_size <= 101,
          "window_size must be odd and in [1, 101]");
    check(std::isfinite(const2_abs) && const2_abs >= 0, "const2_abs must be >= 0");
    check(std::isfinite(const2_rel) && const2_rel >= 0, "const2_rel must be >= 0");
    check(strip_rows >= 1, "strip_rows must be >= 1");
    check(threads >= 1 && threads <= 1024, "threads must be in [1, 1024]");
    check(method == MatchMethod::PatchMatch || method == MatchMethod::Decoupled, "unknown method");
    check(flow.finest_scale >= 0 && flow.finest_scale <= 8, "flow.finest_scale must be in [0, 8]");
    check(flow.patch_size >= 2 && flow.patch_size <= 32, "flow.patch_size must be in [2, 32]");
    check(flow.patch_stride >= 1 && flow.patch_stride < flow.patch_size,
          "flow.patch_stride must be in [1, flow.patch_size)");
    check(flow.backward_patch_stride >= 0 && flow.backward_patch_stride < flow.patch_size,
          "flow.backward_patch_stride must be 0 or in [1, flow.patch_size)");
    check(flow.descent_iterations >= 1 && flow.descent_iterations <= 200,
          "flow.descent_iterations must be in [1, 200]");
    check(flow.refine_iterations >= 0 && flow.refine_iterations <= 100,
          "flow.refine_iterations must be in [0, 100]");
    check(flow.prior_track_step >= 0 && flow.prior_track_step <= 256, "flow.prior_track_step must be in [0, 256]");
    check(flow.rigid_choice_radius >= 0 && flow.rigid_choice_radius <= 16, "flow.rigid_choice_radius must be in [0, 16]");
    check(stream_lidar_frames >= 0 && stream_lidar_frames <= kMaxStreamLidarFrames,
          "stream_lidar_frames must be in [0, 16]");
    stereo.validate();
    check(use_lidar || (!support_window && !const1 && !const2),
          "support_window / const1 / const2 need use_lidar");
    check(support_window || (!const1 && !const2), "const1 / const2 act inside support windows: "
                                                  "they need support_window");
}

}  // namespace lidarflow::matching
