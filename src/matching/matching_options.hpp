// SPDX-License-Identifier: MIT
#pragma once
// Knobs of the LiDAR-supported scene-flow matcher (paper Sec. "LiDAR-Supported Matching").
//
// The paper's ablation (Table I) is expressed as switches of the one matcher:
//  - im-only:  use_lidar = false. Pure image cost C_I (Eq. 3) everywhere, random init.
//  - im+LiDAR: LiDAR pixels of D_l^0 become seeds with d0 fixed to the measurement and the
//              cost C_{D_l^0} (Eq. 7); a flow target that lands exactly on a D_l^1 pixel ties
//              d1 to that measurement and switches to C_{D_l^1} (Eq. 10) / C_{D_l^0 D_l^1}
//              (Eq. 12).
//  - +win:     support windows (window_size^2 around each LiDAR point): seeds inside a D_l^0
//              window start, on the coarsest level, from the nearest measurement's d0; a flow
//              target inside a D_l^1 window counts as a D_l^1 hit (so the sparse D_l^1 is
//              actually met, which the paper names as the window's second purpose).
//  - +const1:  constraint 1 = the LiDAR cost cases decide inside windows too: seeds inside a
//              D_l^0 window are scored with C_{D_l^0} (resp. C_{D_l^0 D_l^1}), i.e. matches
//              propagated into window pixels must minimise the LiDAR-case cost (Fig. 3/4).
//  - +const2:  constraint 2 = the disparity space around the LiDAR value: inside a D_l^0
//              window d0, and for targets inside a D_l^1 window d1, are kept within
//              value +- max(const2_abs, const2_rel * value); propagated / random candidates
//              are clamped into that interval.
//
// Decisions where the paper is silent (measured on the two shared KITTI frames):
//  - Case costs are weighted *means* of their terms (see cost_cases.hpp) so they share a scale.
//  - Whether a seed is in a D_l^1 case is decided once per seed visit from its current match;
//    all candidates of that visit are scored with the same formula. Deciding per candidate let
//    flow targets be attracted into D_l^1 windows merely because the C_{D_l^1} mean is lower
//    than the C_I mean (Fl outliers +1.8 points).
//  - A match whose image position leaves an image costs out_of_image_penalty per patch sample;
//    300 (below the median matched cost) made out-of-image matches win everywhere (SF 59 %).
//  - keep_disparity_change (default true): when a LiDAR rule moves the d0 of a neighbour's
//    match propagated into a seed (LiDAR pixel: d0 := measurement; constraint 2: clamp into
//    the interval), its d1 moves by the same amount: the seed takes the neighbour's motion
//    (u, v, d1 - d0) on its own LiDAR depth instead of pairing the corrected d0 with a d1 that
//    belonged to another d0. Random-search candidates are left alone (shifting their d1 too
//    turned every clamped d0 sample into an extra d1 sample for the same accuracy). Neutral on
//    the final SF, kept because the matches it gives are consistent.
//  - d1_terms (default Paper = Eqs. 10 / 12 as printed; ReferenceAnchored is opt-in): the t1
//    stereo term E(l1, r1) of the D_l^1 cases compares two target patches and never the
//    reference point, so with d1 tied to the LiDAR it rewards *any* flow target on the
//    measured surface. ReferenceAnchored replaces it by the cross term E(l0, r1): better
//    matches, but a worse final result on 000002, so it is not the default.
//    Image-only matching is unaffected by both (no LiDAR case, no LiDAR rule).
#include <cstdint>
#include <string>

#include "features/dense_sift.hpp"
#include "matching/cost_cases.hpp"
#include "matching/patch_cost.hpp"
#include "stereo/guided_sgm.hpp"

namespace lidarflow::matching {

// Stage 1's design: the paper's joint 4-D PatchMatch over dense SIFT (scene_flow_matcher.hpp),
// or stereo and flow searched apart (decoupled_matcher.hpp), which presets choose for speed.
enum class MatchMethod { PatchMatch, Decoupled };
// "patchmatch", "decoupled"; parse_match_method throws Error(InvalidArgument) for another name.
const char *match_method_name(MatchMethod m);
MatchMethod parse_match_method(const std::string &name);

// Dense inverse search (OpenCV DISOpticalFlow) of the decoupled design, at the stage's resolution.
struct FlowSearchOptions {
    int finest_scale = 1;        // pyramid level where the search stops (0 = full resolution)
    int patch_size = 8;          // [px]
    int patch_stride = 3;        // [px], < patch_size
    // The backward search's stride [px], < patch_size (0 = patch_stride): only the
    // forward-backward check reads that flow, so it may be coarser than the result's.
    int backward_patch_stride = 0;
    int descent_iterations = 25; // inverse-compositional steps per patch and level
    int refine_iterations = 5;   // variational refinement per level (0 = off)
    // Start the search from the rigid motion of the dominant (static) scene, fitted to sparse
    // tracks and the stereo disparities: DIS's coarse levels then need not find large motion
    // of the near background on their own. The grid step of the tracks [px], 0 = off.
    int prior_track_step = 0;
    // Per pixel, keep the rigid prior's flow instead of DIS's where its photometric error over
    // a (2r + 1)^2 box is lower and the stereo (or LiDAR) disparity it comes from exists: the
    // static scene's exact motion from its measured depth (0 = off; needs prior_track_step).
    int rigid_choice_radius = 0;

    // The options of the backward (t1 -> t0) search: these, with backward_patch_stride's stride.
    FlowSearchOptions backward() const {
        FlowSearchOptions b = *this;
        if (backward_patch_stride > 0) b.patch_stride = backward_patch_stride;
        return b;
    }
};

enum class MatchVariant { ImageOnly, ImLidar, ImLidarWin, ImLidarWinConst1, Full };

// Name as in Table I ("im-only", "im+LiDAR", "im+LiDAR+win", ...).
const char *variant_name(MatchVariant v);

constexpr int kMaxStreamLidarFrames = 16;  // matching_options.cpp's message says 16

struct MatchingOptions {
    MatchMethod method = MatchMethod::PatchMatch;
    FlowSearchOptions flow;  // decoupled design only
    // Decoupled design only: the stereo of both pairs by the project's SGM with the LiDAR term
    // (stereo/guided_sgm.hpp; its range and threads are set by the matcher) instead of OpenCV's
    // StereoSGBM, which takes no prior.
    bool guided_stereo = false;
    // Decoupled and guided only: where the input has no t1 scan, the t1 stereo is guided by the
    // t0 points carried into t1 by the camera's motion (fitted to tracks and the t0 disparity).
    bool carry_lidar = true;
    // Decoupled only, in a stream: the previous pair's movers, carried to this pair's t0, keep
    // their object motion in the flow's prior (matching/motion_prior.hpp).
    bool stream_prior = true;
    // Decoupled only, in a stream: stages 2-4 also see the static LiDAR points of up to this many
    // earlier frames, carried by stage 4's background motion (0 = only the pair's own points).
    int stream_lidar_frames = 0;  // [0, kMaxStreamLidarFrames]
    stereo::GuidedSgmOptions stereo;

    // Pyramid: factor 0.5 per level; levels are added while the coarser image stays at least
    // min_coarsest_height px high (and up to max_levels levels in total).
    int min_coarsest_height = 40;
    int max_levels = 6;

    // Seeds on a regular grid of this step [px] at full resolution; the same seeds, scaled, are
    // used on every level (CPM).
    int grid_step = 3;
    // Seed grid of the backward direction (0 = grid_step): the backward field only serves the
    // round-trip check of stage 2b, where a coarser grid is paired with a wider search for the
    // best round trip (consistency fb_search_radius 2 for a 6 px grid). It trades a little
    // accuracy for time, so only `balanced` takes it.
    int backward_grid_step = 0;
    // Coarse levels need fewer seeds: from this pyramid level on (0 = full resolution; >= 1),
    // each coarser level keeps every second grid node per axis (stride 2, 4, ...). A large value
    // keeps every seed on every level, as CPM does. Thinning from the 1/4 level costs no
    // accuracy; from the 1/2 level it does.
    int thin_from_level = 2;
    // ... but a thinned level keeps at least this many grid seeds (stride halved until it
    // does): too few seeds on the coarsest level lose the match on small images.
    int min_level_seeds = 4000;
    // PatchMatch iterations per level; a level stops early once fewer than stop_ratio of the
    // seeds improved in one iteration. Past the 4th, an iteration improves < 10 % of the seeds
    // but costs as much as the 4th (random search): 4 vs 8 is within noise on the final SF.
    int iterations = 4;
    float stop_ratio = 0.05f;
    // Random search after a level's first iteration only for seeds whose match changed in their
    // last visit (or in this visit's propagation): the others already failed a random search
    // around the same match. Less CPU for about 0.1 point, so it is an option, off by default.
    bool lazy_random_search = false;
    // The lazy rule, only for settled seeds, and only for (u, v) and d0: after a level's first
    // iteration a seed whose match changed neither in its last visit nor by this visit's
    // propagation skips the flow and d0 random searches when its cost is at most settle_ratio x
    // the mean cost of its neighbours' matches (0 = never). The d1 search always runs. Why: the
    // lazy rule's loss came from seeds stuck on a poor match that no neighbour improves, while
    // a seed no costlier than its neighbours is where PatchMatch has converged; d1 is the
    // weakest component (textureless regions, where all costs are alike, need its search).
    // Same accuracy for ~5 % less matching CPU (928da5b; docs/experiments/speed-stage1.md).
    float settle_ratio = 1.0f;
    // Skip a candidate whose four image positions its seed already tried on this level with
    // this case formula: its cost is the same and the seed's best has only improved since, so
    // it cannot win. Exact (results are bit-identical either way); ~30 % of the candidates that
    // reach a cost evaluation repeat one (KITTI 000002, seed 1). Off only to check exactness.
    bool remember_tried = true;
    // Full-resolution bounds of the search space (KITTI-sized defaults).
    float max_flow = 400.0f;      // random init radius of (u, v) on the coarsest level [px]
    float max_disparity = 256.0f; // disparities are searched in [0, max_disparity] [px]

    // Cost (Eq. 2).
    features::DenseSiftOptions sift;
    int patch_radius = 3;  // 7x7 patch
    int patch_step = 3;    // sample every 3rd pixel of it (3x3 samples)
    DescriptorNorm norm = DescriptorNorm::L2;
    // Per patch sample, in descriptor-distance units (descriptors have length 512): about the
    // 99th percentile of matched per-sample costs on KITTI, so a match leaving the image loses
    // against any plausible in-image match but beats clearly wrong ones.
    float out_of_image_penalty = 500.0f;

    // LiDAR support (see the variant table above).
    bool use_lidar = true;
    bool support_window = true;
    bool const1 = true;
    bool const2 = true;
    bool use_lidar1 = true;  // false: D_l^1 is ignored (only D_l^0 supports the matching)
    int window_size = 15;  // odd, full-resolution support window side [px]
    float const2_abs = 2.0f;
    float const2_rel = 0.05f;  // 5 %: the KITTI outlier tolerance
    // Terms of the D_l^1 cases and the d1 update of the LiDAR d0 rules (see the decisions above).
    D1Terms d1_terms = D1Terms::Paper;
    bool keep_disparity_change = true;

    // Strips of this many seed rows are the unit of (deterministic) parallel work.
    int strip_rows = 6;
    uint64_t random_seed = 1;
    int threads = 1;  // OpenMP threads (num_threads clauses only); results do not depend on it

    // The options of one Table-I row, everything else at its default.
    static MatchingOptions for_variant(MatchVariant v);
    // These options with the LiDAR switches of one Table-I row (everything else kept).
    MatchingOptions with_variant(MatchVariant v) const;
    // Throws lidarflow::Error(InvalidArgument) naming the first bad field.
    void validate() const;
};

}  // namespace lidarflow::matching
