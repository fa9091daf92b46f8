// SPDX-License-Identifier: MIT
#pragma once
// Stage 4: LiDAR-supported robust interpolation (paper Sec. "LiDAR-Supported Robust
// Interpolation", Fig. 5), RIC-style (Hu et al., CVPR 2017) extended to all four scene-flow
// components. Sparse matches in I_l^0 -> dense u, v, d0, d1:
//  1. soft edge map of I_l^0 (built-in multi-scale gradient, or a user SED model);
//  2. SLIC superpixels; each one's anchor is its centre, or the closest LiDAR measurement
//     (geometry d0) / LiDAR match (motion u, v and d1; off by default, see
//     lidar_motion_anchors) when that lies inside the superpixel or within
//     lidar_anchor_distance of its centre;
//  3. the K geodesically nearest matches of each anchor (edge-aware neighbourhood);
//  4. per superpixel a plane for d0, a plane for d1 and an affine (u, v) model, from random
//     minimal subsets scored robustly on the neighbourhood, refined by propagation from
//     adjacent superpixels, random search and inlier least squares; a hypothesis that
//     disagrees with the superpixel's LiDAR anchor is rejected outright;
//     with a background model (ego-motion, rigid when run() gets the camera) the d1 and flow
//     models describe only the remainder of the matches after it, "no remainder" is itself a
//     hypothesis, and matches hidden at t1 (measured on the occluder) get the background's;
//  5. every pixel takes its superpixel's models, or an adjacent superpixel's when the matches
//     around it (geodesic Voronoi cell) clearly support that one better (thin structures);
//     the LiDAR point's own cell always keeps its anchored model.
// use_lidar = false is the "Interp-only" ablation: same code, no LiDAR anchors/rejection.
#include <memory>
#include <string>

#include "core/camera.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "interpolation/edge_map.hpp"
#include "motion/ego_motion.hpp"
#include "interpolation/superpixels.hpp"

namespace lidarflow::interpolation {

struct InterpolationOptions {
    bool use_lidar = true;
    EdgeMapOptions edges;          // set edges.method = StructuredForest + sed_model_path for SED
    // region_size ~ sqrt(superpixel area); disparity_weight (over run()'s geometry hint) acts
    // only on superpixels below region_size, those a dense scan sized.
    SuperpixelOptions superpixels;
    // A dense scan supports smaller superpixels (each still holds LiDAR points): the size is
    // sqrt(lidar_points_per_superpixel / points per pixel) of run()'s lidar0, between
    // min_superpixel_size and superpixels.region_size (which sparse LiDAR, or none, keeps).
    // 0 = always region_size (the paper's design).
    float lidar_points_per_superpixel = 0.0f;
    int min_superpixel_size = 10;
    // Below superpixels.region_size, adjacent superpixels are merged, up to region_size^2
    // pixels, where their LiDAR points (>= 4 each) lie on one disparity plane within
    // planar_merge_tolerance px (0 = never), and with merge_unseen where no LiDAR point is in
    // them or their neighbours: a scan's small superpixels stay at depth boundaries.
    float planar_merge_tolerance = 0.0f;
    bool merge_unseen = false;
    float edge_gain = 3.0f;        // geodesic step cost 1 + edge_gain * edge (>= 0)
    // K geodesic nearest matches per anchor (>= 1). The hypotheses are drawn from, and scored
    // on, these K matches; at stage 3's ~6 % density fewer cover too few superpixels to outvote
    // a wrong cluster of matches in a hole. 256 is where the paper protocol and the synthetic
    // scenes stop improving (docs/experiments/accuracy.md, e20ce99).
    int num_neighbors = 256;
    // Neighbour weight exp(-geodesic / distance_sigma) in scoring and sampling (> 0) [px]. On the
    // scale of the neighbourhood's extent (256 neighbours reach ~35-40 px); not wider, because
    // far neighbours then reach across motion boundaries (test_interpolation_background;
    // docs/experiments/accuracy.md, efd9efb).
    float distance_sigma = 36.0f;
    float disparity_inlier = 2.0f;  // robust-cost truncation for d0, d1 residuals [px] (> 0)
    float flow_inlier = 3.0f;       // robust-cost truncation for (u, v) end-point errors [px] (> 0)
    // Random minimal subsets per superpixel and channel (>= 1) at superpixels.region_size; a
    // dense scan's smaller superpixels draw fewer (initial_hypotheses() below).
    int initial_hypotheses = 24;
    int iterations = 4;            // propagation + random-search rounds (>= 0)
    int random_hypotheses = 4;     // new random subsets per round and channel (>= 0)
    // LiDAR: anchor threshold [px] (distance LiDAR pixel - superpixel centre), tolerance of
    // the rejection test for d0 against the measurement and for (u, v) EPE / d1 against the
    // LiDAR match, and the weight of LiDAR seeds in the robust cost.
    // The anchor distance: ~88 points lie ~55 px apart, so a point should anchor more than the
    // one superpixel it falls in; 18 px is the near end of the plateau measured over placements
    // of the paper protocol's grids (the further an anchor reaches, the likelier it crosses a
    // depth edge; docs/experiments/lidar-placement.md, 433a3f9).
    float lidar_anchor_distance = 18.0f;
    float lidar_disparity_tolerance = 1.0f;
    float lidar_match_tolerance = 2.0f;
    float lidar_weight = 1.0f;
    // Anchor the motion models (u, v, d1) on LiDAR matches too (the paper's rule). Off by
    // default: a LiDAR match's motion is an image match like any other (a real scan has no
    // t1 counterpart at all), and anchoring a superpixel on it rejects every hypothesis that
    // disagrees with one possibly wrong match: off was better on both KITTI protocols and the
    // synthetic scene (docs/experiments/accuracy.md). The geometry (d0) anchors are unaffected.
    bool lidar_motion_anchors = false;
    // Pixels may take an adjacent superpixel's model when their nearest matches support it
    // clearly better (thin structures inside coarse superpixels).
    bool pixel_model_selection = true;
    // Interpolate the disparity change d1 - d0 instead of d1 itself and add it to the dense
    // d0: the change varies far less than d1 over a surface (it is ~0 on far background and
    // small on the road), so extrapolating it into holes is much safer, and d1 inherits the
    // LiDAR support of d0 where LiDAR is used.
    bool d1_from_change = true;
    // Fit the dominant rigid motion (ego-motion; motion/ego_motion.hpp) to all matches
    // and interpolate only what it does not explain; d1, u, v then follow the dense d0 into
    // match-free regions. Falls back to d1_from_change when no dominant motion is found. Its
    // gain is limited where the matches lie only on distant surfaces (forward translation then
    // barely separable from rotation without the camera; see rigid_ego_motion).
    bool ego_motion = true;
    // With a valid camera passed to run(), fit the rigid motion instead (ego_motion.hpp,
    // fit_rigid_ego_motion); the calibration-free model otherwise (the camera separates
    // forward translation from rotation).
    bool rigid_ego_motion = true;
    // In the ego-motion fit, a LiDAR pixel's match is triangulated with the measured d0
    // instead of its matched one.
    bool ego_lidar_depth = true;
    // With a valid ego-motion, "no remainder" (the superpixel moves with the background) is a
    // hypothesis of the d1 and flow models, its robust cost scaled by background_preference
    // (in (0, 1]; < 1 favours it where the seeds around are ambiguous, e.g. a few outliers).
    // Kept mild: stronger preferences paint independently moving objects with few matches
    // (the synthetic textureless van) with the background motion.
    bool background_hypothesis = true;
    float background_preference = 0.9f;
    // With a valid ego-motion: matches whose point the other matches hide at t1 (at the pixel
    // the background model predicts) get the background motion, as their d1 / flow were
    // matched on the occluder: d1 when hidden in the right view and the flow is static;
    // d1 and flow when hidden in the left view and the model is the rigid one (camera given).
    // occlusion_margin [px] (> 0): how much nearer the occluder must be (and >= 10 %).
    bool occlusion_reasoning = true;
    float occlusion_margin = 2.0f;
    // With a valid rigid ego-motion (camera given): a pixel whose point leaves the image at t1 by the background
    // model, and by its own interpolated flow too, takes the background's d1 and flow. No match
    // can exist for it, so its model is extrapolated from matches that stay in the image; the
    // second condition leaves objects that the matches show staying in view (a car driven
    // alongside) to their own model (docs/experiments/accuracy.md, b85f504).
    bool exits_follow_background = true;
    // With a valid rigid ego-motion (camera given): a match whose flow the background explains
    // (end-point residual < static_flow_tolerance) is a static point, and a static point's d1
    // follows from its d0 and the camera's motion; its own d1 is a third image match (t1 stereo)
    // and the least reliable of its components. Such a match takes the background's d1
    // (remainder 0). Guard: the flow only tells a static point from one that moves along the
    // optical axis when that motion would shift it visibly. Moving in depth so that d1 changes
    // by delta scales the t1 position about the principal point by delta / d1, i.e. shifts it
    // by r * delta / d1 at r px from the principal point; the rule applies only where that
    // shift, for the match's own d1 discrepancy, is at least static_d1_discrimination px (a
    // car ahead, near the principal point, keeps its measured d1; docs/experiments/accuracy.md,
    // 1dd4a99).
    bool static_d1_from_background = true;
    float static_flow_tolerance = 1.5f;     // [px] (> 0)
    float static_d1_discrimination = 2.0f;  // [px] (>= 0; 0 = no guard)
    // With a valid rigid ego-motion and LiDAR on: the t1 scan's points (run()'s lidar1) become
    // d0 measurements at t0 where the background motion puts them back (P0 = R^T (P1 - t)), as
    // a static point's t1 position and depth fix its t0 ones. A point on an independently
    // moving object lands in the wrong place, so it is dropped when most matches and t0 LiDAR
    // points within lidar1_check_radius of where it lands contradict it: a match's flow
    // remainder after the background exceeds flow_inlier (it moves on its own), or the d0
    // differs from the point's by more than max(3 px, lidar1_relative_tolerance x its d0)
    // (another surface). Where nothing is near (the holes where it helps most) nothing
    // contradicts it: a textureless object that moves on its own without a match or t0 point
    // near is taken as static. A t0 measurement on the same pixel wins. The depth test is
    // relative because a fixed 3 px one also rejects the matches LiDAR corrects
    // (docs/experiments/accuracy.md, 7222f65).
    bool lidar1_from_background = true;
    int lidar1_check_radius = 10;           // [px] half side of the checked window (>= 0)
    float lidar1_relative_tolerance = 0.2f; // (> 0)
    // Knobs of the fit (ranges checked at construction: hypotheses in [1, 100000], inlier
    // thresholds finite > 0, min_inlier_share in [0, 1], min_inliers in [0, 10^8],
    // joint_rounds in [0, 100]); its seed is replaced by random_seed.
    motion::EgoMotionOptions ego;
    // Geometry hint (run()'s optional dense disparity, e.g. the SGM of stage 2a): where the
    // matches leave holes, hint pixels on a grid become extra d0-only seeds with a lower
    // weight. They are never anchors, so LiDAR still rejects any model that disagrees with
    // it, and they are used only where LiDAR vouches for the hint: at least one LiDAR pixel
    // within hint_lidar_radius where the hint agrees with the measurement within
    // hint_lidar_tolerance, and none where it disagrees (no LiDAR: no hint seeds at all).
    bool use_geometry_hint = true;
    int hint_grid = 8;                 // grid step of the hint seeds [px] (>= 1)
    float hint_min_distance = 4.0f;    // only this far from every match [px] (>= 0)
    float hint_weight = 0.5f;          // weight factor against a match in the d0 cost (> 0)
    float hint_lidar_radius = 48.0f;   // LiDAR verification radius [px] (> 0)
    float hint_lidar_tolerance = 1.0f; // |hint - LiDAR| at a LiDAR pixel [px] (> 0)
    // Each LiDAR point's d0 residual (measurement minus the model its pixel uses) spread over
    // the pixels within this radius [px, 0-64] that use the same model (lidar_residuals.hpp;
    // 0 = off): a dense scan's detail inside a superpixel's plane.
    float lidar_residual_radius = 0.0f;
    // The output d0 at LiDAR pixels is the measurement itself (LiDAR is never filtered).
    bool keep_lidar_values = true;
    unsigned random_seed = 1;      // all random draws derive from it and the superpixel index
    int num_threads = 1;           // OpenMP threads; results do not depend on it
};

struct InterpolationTimings {
    // seeds_s: the seeds and the ego-motion fit, before the edges. With two threads or more the
    // superpixels run beside the edges and the seed graph (part of geodesic_s): the phases then
    // add up to more than total_s.
    double seeds_s = 0, edges_s = 0, superpixels_s = 0, geodesic_s = 0, models_s = 0, output_s = 0, total_s = 0;
};

// The superpixel size run() uses for lidar_points LiDAR points on an image of this size
// (InterpolationOptions::lidar_points_per_superpixel).
int superpixel_size(const InterpolationOptions &o, size_t lidar_points, cv::Size image);

// The random minimal subsets a superpixel of side `size` draws at first, of `hypotheses` for
// one of side `largest` (the preset's): in proportion to its area, at least
// kMinInitialHypotheses. Smaller superpixels have more neighbours to take models from, so the
// image's total stays that of the largest size.
constexpr int kMinInitialHypotheses = 4;
int initial_hypotheses(int hypotheses, int size, int largest);

struct InterpolationResult {
    // Dense field: valid = 1 everywhere, d0/d1 >= 0, confidence in [0, 1] = weighted inlier
    // share of the pixel's superpixel models over its neighbourhood (averaged over channels).
    SceneFlowField dense;
    cv::Mat1f edges;          // the edge map used
    cv::Mat1i superpixels;    // superpixel label per pixel
    int num_superpixels = 0;
    int superpixel_size = 0;  // the region size used (options, LiDAR density)
    int lidar_anchored_geometry = 0;  // superpixels whose d0 model is LiDAR-anchored
    int lidar_anchored_motion = 0;    // superpixels whose u, v, d1 models are LiDAR-anchored
    int hint_seeds = 0;               // geometry-hint pixels used as d0 seeds
    int occluded_seeds = 0;           // matches given the background motion as hidden at t1
    int static_d1_seeds = 0;          // matches given the background d1 as static points
    int lidar1_points = 0;            // t1 LiDAR points used as d0 measurements at t0
    motion::EgoMotion ego;            // the background model used (valid = false: none)
    InterpolationTimings timings;
};

// What run() computes of its image alone, computed ahead (a stream's first frame, before its
// pair exists): the edge map, and the superpixels where no dense scan sizes them (they then
// depend on the image alone). run() uses it for an image pixel-identical to `image` and a
// superpixel size equal to `region_size`, and computes afresh otherwise: the same results.
struct ImageWork {
    cv::Mat image;                          // a copy of the image it was computed from
    int region_size = 0;                    // the superpixel size it was computed for
    cv::Mat1f edges;
    std::shared_ptr<const Superpixels> superpixels;  // null when a dense scan sizes them
};

class RobustInterpolator {
public:
    // Validates the options and loads the SED model when edges.method is StructuredForest.
    // Throws Error(InvalidArgument) on options out of range, Error(Io/Format) when the SED
    // model cannot be read. Copies the options; holds the model for its lifetime.
    explicit RobustInterpolator(const InterpolationOptions &options);

    // matches: sparse field in I_l^0 (at least one valid match; finite u, v, d0 >= 0, d1 >= 0
    // where valid). lidar0: D_l^0 points (may be empty; when not, its width/height equal the
    // image's, points inside it, finite disparities >= 0). image: I_l^0, 8-bit gray or BGR,
    // same size. Inputs are only read. Throws Error(SizeMismatch) on differing sizes and
    // Error(InvalidArgument) on any other invalid input. Safe to call from several threads.
    // geometry_hint: optional dense disparity of I_l^0 (invalid < 0; empty = none), e.g. the
    // SGM disparity of stage 2a; non-empty: same size as the image, finite where valid
    // (Error(SizeMismatch / InvalidArgument) otherwise). See use_geometry_hint.
    // camera: the rectified rig of the frame, or an invalid one (default) when unknown; used
    // only by the background model (rigid_ego_motion). Not validated beyond valid().
    // lidar1: D_l^1 points (may be empty; otherwise checked as lidar0), used only with LiDAR on
    // and a rigid background model (lidar1_from_background).
    // threads: OpenMP threads of this call, 0 = options().num_threads (results do not depend on it).
    // work: prepare_image's for this image, or null (see ImageWork); only read.
    InterpolationResult run(const SceneFlowField &matches, const SparseLidar &lidar0, const cv::Mat &image,
                            const DisparityMap &geometry_hint = DisparityMap(),
                            const StereoCamera &camera = StereoCamera(),
                            const SparseLidar &lidar1 = SparseLidar(), int threads = 0,
                            const ImageWork *work = nullptr) const;

    // The ImageWork of `image` for a run whose lidar0 will have `lidar_points` points (the
    // superpixel size depends on their number). Throws as run() does for a bad image or threads.
    // Safe to call from several threads.
    ImageWork prepare_image(const cv::Mat &image, size_t lidar_points, int threads = 0) const;

    const InterpolationOptions &options() const { return options_; }

private:
    InterpolationOptions options_;
    std::shared_ptr<const SedModel> sed_;
};

// One-shot convenience: RobustInterpolator(options).run(...).dense.
SceneFlowField interpolate_scene_flow(const SceneFlowField &matches, const SparseLidar &lidar0,
                                      const cv::Mat &image, const InterpolationOptions &options = {});

}  // namespace lidarflow::interpolation
