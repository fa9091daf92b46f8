// SPDX-License-Identifier: MIT
#pragma once
// The byte format fuzz_capi reads as a sequence of C ABI calls, shared with make_corpus (which
// writes the seeds). Every field is one byte unless noted; a program that ends early reads 0s.
//
//   option count n (mod 16), then n option operations:
//     kind (mod 7: set_int, set_float, set_string, get_int, get_float, get_string, NULL object),
//     key (index into kKeys, mod its size), value (set_*: kInts / kFloats / kStrings index;
//     an index past the table takes the next byte as a small raw value)
//   calibration: mode (mod 12: 0..7 good with lidar_to_camera when mode is odd, 8 NaN fx,
//     9 zero baseline, 10 struct_size 4, 11 NULL), fx (good modes: 20 + byte px),
//     baseline (0.05 + byte / 256 m), create_flags (bit 0: NULL options)
//   then operations until the program ends (at most kMaxOps): op (mod kOpCount), operands:
//     kPush: width - 1 (mod 64), height - 1 (mod 48), format (mod 5; 1..3 valid), stride mode
//       (mod 4: exact, padded by the next byte mod 8, one byte short, 0), flags (bit 0 right
//       image one column wider, bit 1 NULL left data, bit 2 right in another format),
//       motion (int8, px per frame), disparity (mod 16 px), texture seed, timestamp step
//       (int8, x 1000 us), LiDAR kind (mod 6: none given, NONE, POINTS_CAMERA, POINTS_LIDAR,
//       DISPARITY, 7), count (mod 32), stride (mod 4: 0, 12, 16, the next byte mod 12),
//       values (mod 4: consistent with the scene, raw float bytes, table floats, NULL data)
//     kReset, kHasResult: nothing
//     kInfo: struct_size mode (mod 3: exact, 4, larger)
//     kTiming: index (255 = UINT32_MAX), null_mask (bit 0 name, bit 1 seconds)
//     kResult, kPoints: plane mask (bit i: plane i given), size delta (mod 3, minus 1,
//       applied to the width), stride mode (mod 3: exact, padded by 4, one element short)
//     kViews: nothing
//     kRecreate: nothing (destroy, then create again from the same options and calibration)
//     kErrors: a status code byte for lf_status_string
#include <cstdint>

namespace lidarflow::fuzz {

enum CapiOp : uint8_t {
    kPush = 0,
    kReset,
    kHasResult,
    kInfo,
    kTiming,
    kResult,
    kViews,
    kPoints,
    kRecreate,
    kErrors,
    kOpCount
};

constexpr int kMaxOps = 24;

// Every option key, then keys that must be refused.
constexpr const char *kKeys[] = {
    "threads", "preset", "use_lidar", "processing_scale", "last_stage", "support_window",
    "matching.support_windows", "matching.const1", "matching.const2", "matching.use_lidar1",
    "matching.keep_disparity_change", "matching.d1_terms_anchored", "matching.grid_step", "matching.iterations",
    "matching.thin_from_level", "matching.max_levels", "matching.min_coarsest_height",
    "matching.lazy_random_search", "matching.patch_radius", "matching.stop_ratio", "matching.max_flow",
    "matching.max_disparity", "matching.const2_abs", "matching.const2_rel", "matching.random_seed",
    "consistency.sgm_max_diff", "consistency.sgm_keep_unverified", "consistency.sgm_num_disparities",
    "consistency.sgm_block_size", "consistency.fb_max_flow", "consistency.fb_max_d0", "consistency.fb_max_d1",
    "consistency.fb_search_radius", "consistency.keep_unreliable_lidar", "consistency.cluster_max_flow_step",
    "consistency.cluster_max_disp_step", "consistency.cluster_min_size", "consistency.keep_lidar_clusters",
    "consistency.sparsify_block", "consistency.sparsify_support", "interpolation.use_lidar",
    "interpolation.superpixel_size", "interpolation.num_neighbors", "interpolation.iterations",
    "interpolation.initial_hypotheses", "interpolation.random_hypotheses", "interpolation.edge_gain",
    "interpolation.distance_sigma", "interpolation.disparity_inlier", "interpolation.flow_inlier",
    "interpolation.lidar_anchor_distance", "interpolation.pixel_model_selection", "interpolation.keep_lidar_values",
    "interpolation.random_seed", "interpolation.sed_model",
    // added later: appended, so that the seed corpus keeps its keys
    "lidar.visibility_filter", "lidar.visibility_half_width", "lidar.visibility_half_height",
    "lidar.visibility_ratio", "lidar.visibility_margin", "matching.backward_grid_step", "matching.settle_ratio",
    "interpolation.exits_follow_background", "interpolation.static_d1_from_background",
    "interpolation.lidar1_from_background",
    // refused
    "", "threads ", "THREADS", "matching.", "matching.nonexistent", ".threads", "preset\n",
    "interpolation.sed_model.x",
};

constexpr int64_t kInts[] = {0, 1, -1, 2, 3, 4, 7, 8, 15, 16, 17, 31, 32, 33, 63, 64, 100, 101, 255, 256, 257,
                             1000, 1024, 1025, 4096, 4097, 10000, 10001, 16384, 100000000, 100000001,
                             INT64_C(4294967295), INT64_C(4294967296), INT64_C(9007199254740992),
                             INT64_C(9007199254740993), INT32_MIN, INT32_MAX, INT64_MIN, INT64_MAX};

// Raw bit patterns where a literal would not do (NaN, infinities, denormals) are made in
// the target; these are the finite ones.
constexpr double kFloats[] = {0.0,   -0.0, 1.0,    -1.0,  0.5,   0.125,  0.1249, 0.7,    2.0,  10.0,
                              1e-7,  1e-300, 5e-324, 1e300, 1e308, 10000.0, 10000.5, 1e38, 3e38, 1e-40};

constexpr const char *kStrings[] = {"default", "fast", "accurate", "matching", "consistency", "sparse",
                                    "interpolation", "", "DEFAULT", "default\n", "/nonexistent/model.yml.gz",
                                    "/dev/null", "/"};

}  // namespace lidarflow::fuzz
