// SPDX-License-Identifier: MIT
#include "pipeline/option_keys.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/error.hpp"
#include "core/limits.hpp"

namespace lidarflow::pipeline {

using O = EstimatorOptions;

enum class Extra { None, Odd, MultipleOf16, PowerOfTwo };

struct OptionKey {
    const char *name;
    const char *description;  // one line, from the C header's key documentation
    OptionKeyType type;
    double lo, hi;
    bool lo_open;  // (lo, hi] instead of [lo, hi]
    Extra extra;
    int64_t (*get_int)(const O &);
    void (*set_int)(O &, int64_t);
    double (*get_float)(const O &);
    void (*set_float)(O &, double);
};

namespace {

// Accessors of one EstimatorOptions field, as captureless lambdas (function pointers).
#define LF_INT_FIELD(field)                                                                        \
    [](const O &o) -> int64_t { return static_cast<int64_t>(o.field); },                           \
        [](O &o, int64_t v) { o.field = static_cast<decltype(o.field)>(v); }, nullptr, nullptr
#define LF_FLOAT_FIELD(field)                                                                      \
    nullptr, nullptr, [](const O &o) -> double { return o.field; },                                \
        [](O &o, double v) { o.field = static_cast<decltype(o.field)>(v); }

constexpr double kBig = 10000.0;
constexpr double kMaxSeed53 = 9007199254740992.0;  // 2^53: exact as a double

const OptionKey kKeys[] = {
    // general
    {"threads",
     "OpenMP threads of a handle (default: the CPUs it may run on); results do not depend on it",
     OptionKeyType::Int, 1, 256, false, Extra::None, LF_INT_FIELD(threads)},
    {"adaptive_threads",
     "each frame uses at most the CPUs other processes leave idle (at least one); 0 = always threads",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(adaptive_threads)},
    {"frames_in_flight",
     "pairs computed at once, each on threads / frames_in_flight threads (at least 1), results in order; the motion prior comes from the pair that many before",
     OptionKeyType::Int, 1, 64, false, Extra::None, LF_INT_FIELD(frames_in_flight)},
    {"preset",
     "resets every key except threads to the named preset; set it before other keys",
     OptionKeyType::String, 0, 0, false, Extra::None, nullptr, nullptr, nullptr, nullptr},
    {"use_lidar",
     "master LiDAR switch; 0 = image-only pipeline (LiDAR inputs checked but unused)",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(use_lidar)},
    {"input.strict",
     "refuse images of another size than the calibration's (0: a warning once, the calibration used as it is)",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(strict_input)},
    {"processing_scale",
     "every stage runs on the frame resized by this factor; results come back at input size",
     OptionKeyType::Float, 0.125, 1, false, Extra::None, LF_FLOAT_FIELD(processing_scale)},
    {"upscale_edge_step",
     "scaling results back: where d0, u or v jumps more than this [px], take the nearest in intensity (0 = blend)",
     OptionKeyType::Float, 0, 64, false, Extra::None, LF_FLOAT_FIELD(upscale_edge_step)},
    {"last_stage",
     "stop after this stage (default: the dense result)",
     OptionKeyType::String, 0, 0, false, Extra::None, nullptr, nullptr, nullptr, nullptr},
    // The paper has one support window: the matcher's and the consistency check's are the same.
    {"support_window",
     "side [px] of the LiDAR support window of matching and consistency check",
     OptionKeyType::Int, 1, 101, false, Extra::Odd,
     [](const O &o) -> int64_t { return o.matching.window_size; },
     [](O &o, int64_t v) { o.matching.window_size = o.consistency.support_window = static_cast<int>(v); },
     nullptr, nullptr},
    // LiDAR input (lidar/visibility_filter.hpp)
    {"lidar.visibility_filter",
     "remove LiDAR points the left camera cannot see (hidden by a nearer object) before every stage",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(lidar_visibility.enabled)},
    {"lidar.visibility_half_width",
     "half width [px] of the visibility window",
     OptionKeyType::Int, 0, 64, false, Extra::None, LF_INT_FIELD(lidar_visibility.half_width)},
    {"lidar.visibility_half_height",
     "half height [px] of the visibility window (0 = from the scan's ring spacing)",
     OptionKeyType::Int, 0, 64, false, Extra::None,
     LF_INT_FIELD(lidar_visibility.half_height)},
    {"lidar.visibility_ratio",
     "a point of disparity d is hidden when its window has one above d * (1 + ratio) + margin",
     OptionKeyType::Float, 0, 10, false, Extra::None, LF_FLOAT_FIELD(lidar_visibility.ratio)},
    {"lidar.visibility_margin",
     "the margin [px of disparity] of that visibility test",
     OptionKeyType::Float, 0, kMaxLidarDisparity, false, Extra::None,
     LF_FLOAT_FIELD(lidar_visibility.margin)},
    {"lidar.cell",
     "stages 2-4 see at most one LiDAR point per cell x cell px (0 = every point; stage 1 sees all)",
     OptionKeyType::Int, 0, 64, false, Extra::None, LF_INT_FIELD(lidar_cell)},
    // stage 1
    {"matching.method",
     "stage 1: the paper's joint 4-D PatchMatch, or decoupled SGM stereo + DIS flow",
     OptionKeyType::String, 0, 0, false, Extra::None, nullptr, nullptr, nullptr, nullptr},
    {"matching.flow_finest_scale",
     "(decoupled) DIS's finest pyramid level (0 = full resolution)",
     OptionKeyType::Int, 0, 8, false, Extra::None, LF_INT_FIELD(matching.flow.finest_scale)},
    {"matching.flow_patch_size",
     "(decoupled) DIS patch side [px]",
     OptionKeyType::Int, 2, 32, false, Extra::None, LF_INT_FIELD(matching.flow.patch_size)},
    {"matching.flow_patch_stride",
     "(decoupled) DIS patch stride [px], < flow_patch_size",
     OptionKeyType::Int, 1, 31, false, Extra::None, LF_INT_FIELD(matching.flow.patch_stride)},
    {"matching.flow_backward_patch_stride",
     "(decoupled) DIS patch stride [px] of the backward flow, which only the forward-backward check reads (0 = flow_patch_stride)",
     OptionKeyType::Int, 0, 31, false, Extra::None, LF_INT_FIELD(matching.flow.backward_patch_stride)},
    {"matching.flow_descent_iterations",
     "(decoupled) DIS descent iterations per patch and level",
     OptionKeyType::Int, 1, 200, false, Extra::None,
     LF_INT_FIELD(matching.flow.descent_iterations)},
    {"matching.flow_refine_iterations",
     "(decoupled) DIS variational refinement iterations per level (0 = off; more runs OpenCV's DIS, the only one with it)",
     OptionKeyType::Int, 0, 100, false, Extra::None,
     LF_INT_FIELD(matching.flow.refine_iterations)},
    {"matching.flow_prior_track_step",
     "(decoupled) grid step [px] of the tracks the rigid start flow is fitted to (0 = off)",
     OptionKeyType::Int, 0, 256, false, Extra::None,
     LF_INT_FIELD(matching.flow.prior_track_step)},
    {"matching.flow_rigid_choice_radius",
     "(decoupled) take the rigid start flow where its (2r+1)^2 photometric error is lower (0 = off)",
     OptionKeyType::Int, 0, 16, false, Extra::None,
     LF_INT_FIELD(matching.flow.rigid_choice_radius)},
    {"matching.guided_stereo",
     "(decoupled) stereo by the library's SGM with the LiDAR in its cost; 0 = OpenCV's StereoSGBM",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.guided_stereo)},
    {"matching.carry_lidar",
     "(decoupled, guided) without a t1 scan, guide the t1 stereo by t0 points moved by the camera's motion",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.carry_lidar)},
    {"matching.stream_prior",
     "(decoupled) in a stream, what moved in the previous pair starts this pair's flow",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.stream_prior)},
    {"matching.stream_lidar_frames",
     "(decoupled) in a stream, stages 2-4 also see the static LiDAR points of up to this many earlier frames",
     OptionKeyType::Int, 0, matching::kMaxStreamLidarFrames, false, Extra::None,
     LF_INT_FIELD(matching.stream_lidar_frames)},
    {"stereo.p1",
     "guided SGM: penalty of a 1 px disparity step",
     OptionKeyType::Int, 0, 255, false, Extra::None, LF_INT_FIELD(matching.stereo.p1)},
    {"stereo.p2",
     "guided SGM: penalty of a larger step, > p1",
     OptionKeyType::Int, 1, 1023, false, Extra::None, LF_INT_FIELD(matching.stereo.p2)},
    {"stereo.adaptive_p2",
     "guided SGM: P2 divided by the intensity step",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.stereo.adaptive_p2)},
    {"stereo.paths",
     "guided SGM: aggregation paths",
     OptionKeyType::Int, 4, 8, false, Extra::PowerOfTwo, LF_INT_FIELD(matching.stereo.paths)},
    {"stereo.uniqueness_ratio",
     "guided SGM: margin [%] of the best cost over the second best",
     OptionKeyType::Int, 0, 99, false, Extra::None,
     LF_INT_FIELD(matching.stereo.uniqueness_ratio)},
    {"stereo.census_threshold",
     "guided SGM: a census bit where a neighbour is darker (ternary: or brighter) by more than this [grey levels]",
     OptionKeyType::Int, 0, 64, false, Extra::None, LF_INT_FIELD(matching.stereo.census_threshold)},
    {"stereo.ternary_census",
     "guided SGM: a second census bit per neighbour, brighter by more than the threshold",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.stereo.ternary_census)},
    {"stereo.lidar_slope",
     "guided SGM: LiDAR cost per px of |d - d_lidar|",
     OptionKeyType::Float, 0, 64, false, Extra::None, LF_FLOAT_FIELD(matching.stereo.lidar_slope)},
    {"stereo.lidar_cap",
     "guided SGM: largest LiDAR cost (census costs are 0..62)",
     OptionKeyType::Int, 0, 192, false, Extra::None, LF_INT_FIELD(matching.stereo.lidar_cap)},
    {"stereo.lidar_radius",
     "guided SGM: a point guides pixels this near [px] of its intensity, less with distance",
     OptionKeyType::Int, 0, 32, false, Extra::None, LF_INT_FIELD(matching.stereo.lidar_radius)},
    {"stereo.lidar_intensity",
     "guided SGM: intensity tolerance of that spread",
     OptionKeyType::Int, 0, 255, false, Extra::None,
     LF_INT_FIELD(matching.stereo.lidar_intensity)},
    {"matching.support_windows",
     "(patchmatch) LiDAR support windows (needs use_lidar)",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.support_window)},
    {"matching.const1",
     "(patchmatch) constraint 1: LiDAR cost cases decide inside windows (needs support_windows)",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.const1)},
    {"matching.const2",
     "(patchmatch) constraint 2: disparities kept near the LiDAR value inside windows (needs support_windows)",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.const2)},
    {"matching.use_lidar1",
     "(patchmatch) use the LiDAR of the second frame",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.use_lidar1)},
    {"matching.keep_disparity_change",
     "(patchmatch) a LiDAR rule that moves a propagated d0 moves its d1 along",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(matching.keep_disparity_change)},
    {"matching.d1_terms_anchored",
     "(patchmatch) D_l^1 cases use E(l0,r1) instead of the paper's E(l1,r1)",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     [](const O &o) -> int64_t { return o.matching.d1_terms == matching::D1Terms::ReferenceAnchored ? 1 : 0; },
     [](O &o, int64_t v) { o.matching.d1_terms = v ? matching::D1Terms::ReferenceAnchored : matching::D1Terms::Paper; },
     nullptr, nullptr},
    {"matching.grid_step",
     "(patchmatch) seed grid step [px]",
     OptionKeyType::Int, 1, 32, false, Extra::None, LF_INT_FIELD(matching.grid_step)},
    {"matching.backward_grid_step",
     "(patchmatch) seed grid step of the backward direction, used by the round-trip check (0 = grid_step)",
     OptionKeyType::Int, 0, 32, false, Extra::None, LF_INT_FIELD(matching.backward_grid_step)},
    {"matching.iterations",
     "(patchmatch) PatchMatch iterations per level",
     OptionKeyType::Int, 1, 100, false, Extra::None, LF_INT_FIELD(matching.iterations)},
    {"matching.thin_from_level",
     "(patchmatch) from this pyramid level on, each coarser level keeps every 2nd seed per axis",
     OptionKeyType::Int, 1, 100, false, Extra::None, LF_INT_FIELD(matching.thin_from_level)},
    {"matching.max_levels",
     "(patchmatch) pyramid levels at most",
     OptionKeyType::Int, 1, 10, false, Extra::None, LF_INT_FIELD(matching.max_levels)},
    {"matching.min_coarsest_height",
     "(patchmatch) the coarsest pyramid level stays at least this high [px]",
     OptionKeyType::Int, 8, 4096, false, Extra::None,
     LF_INT_FIELD(matching.min_coarsest_height)},
    {"matching.lazy_random_search",
     "(patchmatch) after a level's first iteration, random search only for seeds whose match changed",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(matching.lazy_random_search)},
    {"matching.settle_ratio",
     "(patchmatch) skip flow and d0 random search of settled seeds costing <= this x their neighbours' (0 = off)",
     OptionKeyType::Float, 0, 100, false, Extra::None, LF_FLOAT_FIELD(matching.settle_ratio)},
    {"matching.descriptor_bits",
     "(patchmatch) SIFT descriptor bits: 4 = packed, less memory, coarser costs in faint texture",
     OptionKeyType::Int, 4, 8, false, Extra::PowerOfTwo, LF_INT_FIELD(matching.sift.bits)},
    {"matching.patch_radius",
     "(patchmatch) radius [px] of the matching cost's patch",
     OptionKeyType::Int, 0, 16, false, Extra::None, LF_INT_FIELD(matching.patch_radius)},
    {"matching.stop_ratio",
     "(patchmatch) a level stops once fewer than this share of seeds improved in an iteration",
     OptionKeyType::Float, 0, 1, false, Extra::None, LF_FLOAT_FIELD(matching.stop_ratio)},
    {"matching.max_flow",
     "(patchmatch) random initial flow radius [px] on the coarsest level",
     OptionKeyType::Float, 1, kBig, false, Extra::None, LF_FLOAT_FIELD(matching.max_flow)},
    {"matching.max_disparity",
     "(patchmatch) disparities are searched in [0, max_disparity] [px]",
     OptionKeyType::Float, 1, kBig, false, Extra::None, LF_FLOAT_FIELD(matching.max_disparity)},
    {"matching.const2_abs",
     "(patchmatch) constraint 2's interval: LiDAR value +- max(const2_abs [px], const2_rel x value)",
     OptionKeyType::Float, 0, kBig, false, Extra::None, LF_FLOAT_FIELD(matching.const2_abs)},
    {"matching.const2_rel",
     "(patchmatch) the relative part of constraint 2's interval",
     OptionKeyType::Float, 0, 10, false, Extra::None, LF_FLOAT_FIELD(matching.const2_rel)},
    {"matching.random_seed",
     "(patchmatch) seed of the random search",
     OptionKeyType::Int, 0, kMaxSeed53, false, Extra::None, LF_INT_FIELD(matching.random_seed)},
    // stages 2-3
    {"consistency.sgm_max_diff",
     "remove a match whose |d0 - SGM disparity| exceeds this [px]",
     OptionKeyType::Float, 0, kBig, true, Extra::None, LF_FLOAT_FIELD(consistency.sgm_max_diff)},
    {"consistency.sgm_keep_unverified",
     "keep matches SGM cannot verify",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(consistency.sgm_keep_unverified)},
    {"consistency.sgm_num_disparities",
     "SGM search range [px] of the consistency check",
     OptionKeyType::Int, 16, 1024, false, Extra::MultipleOf16,
     LF_INT_FIELD(consistency.sgm.num_disparities)},
    {"consistency.sgm_block_size",
     "SGM block size of the consistency check",
     OptionKeyType::Int, 1, 31, false, Extra::Odd, LF_INT_FIELD(consistency.sgm.block_size)},
    {"consistency.fb_max_flow",
     "forward-backward limit [px] of the flow's round trip",
     OptionKeyType::Float, 0, kBig, true, Extra::None, LF_FLOAT_FIELD(consistency.fb_max_flow)},
    {"consistency.fb_max_d0",
     "forward-backward limit [px] of d0",
     OptionKeyType::Float, 0, kBig, true, Extra::None, LF_FLOAT_FIELD(consistency.fb_max_d0)},
    {"consistency.fb_max_d1",
     "forward-backward limit [px] of d1",
     OptionKeyType::Float, 0, kBig, true, Extra::None, LF_FLOAT_FIELD(consistency.fb_max_d1)},
    {"consistency.fb_search_radius",
     "the backward field is searched this many px around the round trip's end",
     OptionKeyType::Int, 0, 8, false, Extra::None,
     LF_INT_FIELD(consistency.fb_search_radius)},
    {"consistency.keep_unreliable_lidar",
     "keep LiDAR matches whose motion fails the round trip",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(consistency.keep_unreliable_lidar)},
    {"consistency.cluster_max_flow_step",
     "neighbouring matches join one cluster when |du|, |dv| <= this [px]",
     OptionKeyType::Float, 0, kBig, true, Extra::None,
     LF_FLOAT_FIELD(consistency.cluster_max_flow_step)},
    {"consistency.cluster_max_disp_step",
     "neighbouring matches join one cluster when |dd0|, |dd1| <= this [px] too",
     OptionKeyType::Float, 0, kBig, true, Extra::None,
     LF_FLOAT_FIELD(consistency.cluster_max_disp_step)},
    {"consistency.cluster_min_size",
     "clusters with fewer matches are removed",
     OptionKeyType::Int, 1, 100000000, false, Extra::None,
     LF_INT_FIELD(consistency.cluster_min_size)},
    {"consistency.keep_lidar_clusters",
     "a cluster holding a trusted LiDAR pixel is kept whatever its size",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(consistency.keep_lidar_clusters)},
    {"consistency.sparsify_block",
     "stage 3 keeps the most consistent match per block of this side [px] (1 = no sparsification)",
     OptionKeyType::Int, 1, 64, false, Extra::None, LF_INT_FIELD(consistency.sparsify_block)},
    {"consistency.sparsify_support",
     "side [px] of the window a match's consistency is averaged over",
     OptionKeyType::Int, 1, 63, false, Extra::Odd,
     LF_INT_FIELD(consistency.sparsify_support)},
    // stage 4
    {"interpolation.use_lidar",
     "stage 4: LiDAR anchors",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(interpolation.use_lidar)},
    {"interpolation.superpixel_size",
     "superpixel side [px] (the largest, with dense LiDAR)",
     OptionKeyType::Int, 4, 512, false, Extra::None,
     LF_INT_FIELD(interpolation.superpixels.region_size)},
    {"interpolation.superpixel_disparity_weight",
     "a dense scan's superpixels follow the stereo's depth too: weight of a squared disparity difference against Lab's (0 = colour only)",
     OptionKeyType::Float, 0, 10000, false, Extra::None,
     LF_FLOAT_FIELD(interpolation.superpixels.disparity_weight)},
    {"interpolation.lidar_points_per_superpixel",
     "a dense scan gets smaller superpixels: sqrt(this / LiDAR points per pixel) (0 = always superpixel_size)",
     OptionKeyType::Float, 0, 10000, false, Extra::None,
     LF_FLOAT_FIELD(interpolation.lidar_points_per_superpixel)},
    {"interpolation.min_superpixel_size",
     "smallest superpixel side [px] of that rule",
     OptionKeyType::Int, 4, 512, false, Extra::None,
     LF_INT_FIELD(interpolation.min_superpixel_size)},
    {"interpolation.planar_merge",
     "merge a dense scan's small superpixels whose LiDAR points lie on one plane within this [px] (0 = never)",
     OptionKeyType::Float, 0, 100, false, Extra::None,
     LF_FLOAT_FIELD(interpolation.planar_merge_tolerance)},
    {"interpolation.merge_unseen",
     "merge a dense scan's small superpixels that no LiDAR point reaches (0/1)",
     OptionKeyType::Bool, 0, 1, false, Extra::None, LF_INT_FIELD(interpolation.merge_unseen)},
    {"interpolation.lidar_residual_radius",
     "each LiDAR point's d0 residual spread over the pixels of its model within this radius [px] (0 = off)",
     OptionKeyType::Float, 0, 64, false, Extra::None,
     LF_FLOAT_FIELD(interpolation.lidar_residual_radius)},
    {"interpolation.num_neighbors",
     "geodesic nearest matches per superpixel",
     OptionKeyType::Int, 1, 4096, false, Extra::None,
     LF_INT_FIELD(interpolation.num_neighbors)},
    {"interpolation.iterations",
     "propagation + random-search rounds",
     OptionKeyType::Int, 0, 1000, false, Extra::None, LF_INT_FIELD(interpolation.iterations)},
    {"interpolation.initial_hypotheses",
     "random minimal subsets per superpixel and channel",
     OptionKeyType::Int, 1, 10000, false, Extra::None,
     LF_INT_FIELD(interpolation.initial_hypotheses)},
    {"interpolation.random_hypotheses",
     "new random subsets per round and channel",
     OptionKeyType::Int, 0, 10000, false, Extra::None,
     LF_INT_FIELD(interpolation.random_hypotheses)},
    {"interpolation.ego_hypotheses",
     "RANSAC sets of the background motion",
     OptionKeyType::Int, 1, 100000, false, Extra::None,
     LF_INT_FIELD(interpolation.ego.hypotheses)},
    {"interpolation.edge_gain",
     "geodesic step cost 1 + edge_gain x edge strength",
     OptionKeyType::Float, 0, kBig, false, Extra::None, LF_FLOAT_FIELD(interpolation.edge_gain)},
    {"interpolation.distance_sigma",
     "neighbour weight scale [px]",
     OptionKeyType::Float, 0, kBig, true, Extra::None,
     LF_FLOAT_FIELD(interpolation.distance_sigma)},
    {"interpolation.disparity_inlier",
     "robust-cost truncation of d0, d1 residuals [px]",
     OptionKeyType::Float, 0, kBig, true, Extra::None,
     LF_FLOAT_FIELD(interpolation.disparity_inlier)},
    {"interpolation.flow_inlier",
     "robust-cost truncation of (u, v) end-point errors [px]",
     OptionKeyType::Float, 0, kBig, true, Extra::None, LF_FLOAT_FIELD(interpolation.flow_inlier)},
    {"interpolation.lidar_anchor_distance",
     "a LiDAR point anchors superpixels whose centre is this near [px]",
     OptionKeyType::Float, 0, kBig, false, Extra::None,
     LF_FLOAT_FIELD(interpolation.lidar_anchor_distance)},
    {"interpolation.pixel_model_selection",
     "pixels may take an adjacent superpixel's model when their matches support it better",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(interpolation.pixel_model_selection)},
    {"interpolation.exits_follow_background",
     "pixels that leave the image at t1 take the background's d1 and flow",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(interpolation.exits_follow_background)},
    {"interpolation.static_d1_from_background",
     "matches whose flow the background explains take its d1",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(interpolation.static_d1_from_background)},
    {"interpolation.lidar1_from_background",
     "t1 LiDAR points moved back by the background motion measure d0",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(interpolation.lidar1_from_background)},
    {"interpolation.keep_lidar_values",
     "the output d0 at LiDAR pixels is the measurement itself",
     OptionKeyType::Bool, 0, 1, false, Extra::None,
     LF_INT_FIELD(interpolation.keep_lidar_values)},
    {"interpolation.random_seed",
     "seed of stage 4's random draws",
     OptionKeyType::Int, 0, 4294967295.0, false, Extra::None,
     LF_INT_FIELD(interpolation.random_seed)},
    {"interpolation.sed_model",
     "path of an OpenCV structured-edge model; \"\" = built-in edges",
     OptionKeyType::String, 0, 0, false, Extra::None, nullptr, nullptr, nullptr, nullptr},
};

#undef LF_INT_FIELD
#undef LF_FLOAT_FIELD

const char *type_name(OptionKeyType t) {
    switch (t) {
    case OptionKeyType::Int: return "an integer";
    case OptionKeyType::Bool: return "a 0/1 switch";
    case OptionKeyType::Float: return "a float";
    case OptionKeyType::String: return "a string";
    }
    return "?";
}

std::string number(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

// A float key's value is a float32: its shortest decimal that reads back as the same float
// ("0.05", not the double expansion "0.05000000074505806").
std::string float_number(double v) {
    char buf[64];
    for (int digits = 1; digits <= 9; ++digits) {
        std::snprintf(buf, sizeof buf, "%.*g", digits, v);
        if (static_cast<float>(std::strtod(buf, nullptr)) == static_cast<float>(v)) break;
    }
    return buf;
}

std::string bounds_text(const OptionKey &k) {
    if (k.type == OptionKeyType::Bool) return "0 or 1";
    std::string s = (k.lo_open ? "(" : "[") + number(k.lo) + ", " + number(k.hi) + "]";
    if (k.extra == Extra::Odd) s += " and odd";
    if (k.extra == Extra::MultipleOf16) s += " and a multiple of 16";
    if (k.extra == Extra::PowerOfTwo) s += " and a power of two";
    return s;
}

void check_bounds(const OptionKey &k, double v, const std::string &shown) {
    bool ok = std::isfinite(v) && (k.lo_open ? v > k.lo : v >= k.lo) && v <= k.hi;
    if (ok && k.extra == Extra::Odd) ok = std::fmod(v, 2.0) != 0.0;
    if (ok && k.extra == Extra::MultipleOf16) ok = std::fmod(v, 16.0) == 0.0;
    if (ok && k.extra == Extra::PowerOfTwo) ok = (static_cast<int64_t>(v) & (static_cast<int64_t>(v) - 1)) == 0;
    require(ok, ErrorCode::InvalidArgument,
            std::string("option '") + k.name + "' must be " + bounds_text(k) + ", got " + shown);
}

[[noreturn]] void wrong_type(const OptionKey &k, const char *used) {
    throw Error(ErrorCode::InvalidArgument,
                std::string("option '") + k.name + "' is " + type_name(k.type) + " option; " + used + " does not apply");
}

bool is_key(const OptionKey &k, const char *name) { return std::string(k.name) == name; }

}  // namespace

const OptionKey *find_option_key(const std::string &key) {
    for (const OptionKey &k : kKeys)
        if (key == k.name) return &k;
    return nullptr;
}

OptionKeyType option_key_type(const OptionKey &k) { return k.type; }

std::vector<std::string> option_key_names() {
    std::vector<std::string> names;
    for (const OptionKey &k : kKeys) names.emplace_back(k.name);
    return names;
}

std::vector<OptionKeyDescription> describe_option_keys(const OptionValues &values) {
    std::vector<OptionKeyDescription> rows;
    for (const OptionKey &k : kKeys) {
        OptionKeyDescription d;
        d.name = k.name;
        d.description = k.description;
        switch (k.type) {
        case OptionKeyType::Int: d.type = "int"; break;
        case OptionKeyType::Bool: d.type = "0/1"; break;
        case OptionKeyType::Float: d.type = "float"; break;
        case OptionKeyType::String: d.type = "string"; break;
        }
        if (k.type != OptionKeyType::String) d.bounds = bounds_text(k);
        else if (is_key(k, "preset")) d.bounds = "default | paper | balanced | fast | realtime";
        else if (is_key(k, "matching.method")) d.bounds = "patchmatch | decoupled";
        else if (is_key(k, "last_stage")) d.bounds = "matching | consistency | sparse | interpolation";
        else d.bounds = "a file path, or \"\"";
        if (k.type == OptionKeyType::String) d.value = std::string("\"") + get_option_string(values, k) + "\"";
        else if (k.type == OptionKeyType::Float) d.value = float_number(get_option_float(values, k));
        else d.value = std::to_string(get_option_int(values, k));
        rows.push_back(std::move(d));
    }
    return rows;
}

void set_option_int(OptionValues &values, const OptionKey &k, int64_t v) {
    if (k.type == OptionKeyType::Float) return set_option_float(values, k, static_cast<double>(v));
    if (k.type == OptionKeyType::String) wrong_type(k, "lf_options_set_int");
    // Compare as integers: large int64 values do not survive a trip through double (bounds
    // are integers of at most 2^53, exact in both types).
    const bool in_range = v >= static_cast<int64_t>(k.lo) && v <= static_cast<int64_t>(k.hi);
    check_bounds(k, in_range ? static_cast<double>(v) : std::nan(""), std::to_string(v));
    k.set_int(values.estimator, v);
}

void set_option_float(OptionValues &values, const OptionKey &k, double v) {
    if (k.type != OptionKeyType::Float) wrong_type(k, "lf_options_set_float");
    check_bounds(k, v, number(v));
    k.set_float(values.estimator, v);
}

void set_option_string(OptionValues &values, const OptionKey &k, const std::string &v) {
    if (k.type != OptionKeyType::String) wrong_type(k, "lf_options_set_string");
    if (is_key(k, "preset")) {
        values = preset_values(v, values);
    } else if (is_key(k, "last_stage")) {
        values.estimator.last_stage = parse_stage(v);
    } else if (is_key(k, "matching.method")) {
        values.estimator.matching.method = matching::parse_match_method(v);
    } else {  // interpolation.sed_model
        interpolation::EdgeMapOptions &e = values.estimator.interpolation.edges;
        e.sed_model_path = v;
        e.method = v.empty() ? interpolation::EdgeMapOptions{}.method : interpolation::EdgeMethod::StructuredForest;
    }
}

int64_t get_option_int(const OptionValues &values, const OptionKey &k) {
    if (k.type != OptionKeyType::Int && k.type != OptionKeyType::Bool) wrong_type(k, "lf_options_get_int");
    return k.get_int(values.estimator);
}

double get_option_float(const OptionValues &values, const OptionKey &k) {
    if (k.type == OptionKeyType::Float) return k.get_float(values.estimator);
    if (k.type == OptionKeyType::String) wrong_type(k, "lf_options_get_float");
    return static_cast<double>(k.get_int(values.estimator));
}

const char *get_option_string(const OptionValues &values, const OptionKey &k) {
    if (k.type != OptionKeyType::String) wrong_type(k, "lf_options_get_string");
    if (is_key(k, "preset")) return values.preset.c_str();
    if (is_key(k, "last_stage")) return stage_name(values.estimator.last_stage);
    if (is_key(k, "matching.method")) return matching::match_method_name(values.estimator.matching.method);
    return values.estimator.interpolation.edges.sed_model_path.c_str();
}

std::string result_settings_text(const EstimatorOptions &options) {
    OptionValues values;
    values.estimator = options;
    std::string text;
    for (const OptionKey &k : kKeys) {
        if (is_key(k, "threads") || is_key(k, "adaptive_threads") || is_key(k, "preset")) continue;
        // Results made one pair at a time say so; a stream's settings read as before the key existed.
        if (is_key(k, "frames_in_flight") && options.frames_in_flight == 1) continue;
        text += k.name;
        text += '=';
        if (k.type == OptionKeyType::String) {
            text += get_option_string(values, k);
        } else if (k.type == OptionKeyType::Float) {
            char buf[40];
            std::snprintf(buf, sizeof buf, "%.17g", get_option_float(values, k));
            text += buf;
        } else {
            text += std::to_string(get_option_int(values, k));
        }
        text += '\n';
    }
    return text;
}

OptionValues preset_values(const std::string &name, const OptionValues &current) {
    // The core owns the preset table, so the C ABI, the CLI's --preset, --set preset=..,
    // Python and the bridge all get the same values.
    OptionValues v;
    v.estimator = EstimatorOptions::preset(name);
    v.preset = name;
    v.estimator.threads = current.estimator.threads;
    return v;
}

}  // namespace lidarflow::pipeline
