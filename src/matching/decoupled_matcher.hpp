// SPDX-License-Identifier: MIT
#pragma once
// Stage 1, decoupled design: the 4-D scene-flow search split into what each part needs.
//  - d0 and d1 from semi-global stereo matching of each stereo pair: the project's SGM with the
//    pair's LiDAR points in its data cost (guided_stereo), or OpenCV StereoSGBM; the t0
//    disparity is also stage 2's SGM reference, so it is computed once for both stages.
//  - (u, v) from dense inverse search (OpenCV DISOpticalFlow) between the left images, t0 -> t1
//    (and t1 -> t0 for the round-trip check of stage 2b).
//  - d1 of a pixel is the t1 disparity at its flow target (nearest pixel).
// LiDAR enters the stereo cost (guided), at the pixels it measures (d0 := the measurement) and,
// through stages 2-4, as the anchor of the interpolation. Each part runs at O(pixels x range)
// with small, cache-resident working sets, instead of PatchMatch over 128-byte descriptors in
// four dimensions.
#include <cstdint>
#include <memory>

#include <opencv2/core.hpp>
#include <opencv2/video/tracking.hpp>

#include "consistency/options.hpp"
#include "core/camera.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "flow/dis.hpp"
#include "matching/matching_options.hpp"
#include "matching/motion_prior.hpp"
#include "matching/scene_flow_matcher.hpp"

namespace lidarflow::matching {

struct DecoupledResult {
    SceneFlowField forward;   // reference I_l^0; valid where stereo and flow give a 4-vector
    SceneFlowField backward;  // reference I_l^1; empty unless asked for
    DisparityMap sgm0;        // SGM disparity of (I_l^0, I_r^0), invalid < 0
    DisparityMap sgm1;        // SGM disparity of (I_l^1, I_r^1), invalid < 0
    bool reused_t0 = false;   // sgm0 came from the caller's t0_reuse
    // The grid tracks fit a rigid background motion (where DIS starts); false also when the
    // tracks are off (prior_track_step 0). A pair without one is no continuous stream (a cut,
    // a swapped frame): the estimator makes no prior from it.
    bool tracked_motion = false;
    // sgm0 came from t0_reuse, over a time step like the one that made it, and the tracks fit a
    // calibrated motion: t0_reuse's priors (its movers, its carried points) apply to this pair.
    bool stream_continues = false;
    // The points that guided sgm1: the t1 scan's, or where there is none (and carry_lidar), the
    // t0 points carried by the camera's motion.
    SparseLidar guide1;
    // I_l^1 prepared for the flow search (null where OpenCV's DIS searched): the next pair's t0.
    std::shared_ptr<const flow::DisPyramid> pyramid1;
    double seconds_stereo = 0;  // both pairs' stereo
    double seconds_flow = 0;    // rigid prior, then both directions' DIS
};

// What a stream may hand from one frame to the next: the newer pair's stereo disparity (frame
// k's t1 pair is frame k+1's t0 pair). Immutable once made.
struct DecoupledStereo {
    cv::Mat left, right;  // deep copies of the pair it describes
    SparseLidar lidar;    // the points that guided it (none for StereoSGBM)
    DisparityMap disparity;
    // The pair's movers as carry_object_motion leaves them at these images' pixels (the next
    // pair's prior); empty when the pair had no calibrated background motion.
    cv::Mat3f object_motion;
    // Static LiDAR points of this and earlier pairs at these images' pixels (the next pair's
    // extra t0 points, MatchingOptions::stream_lidar_frames); empty when off or not made.
    CarriedLidar carried;
    int64_t step_us = 0;  // t1 - t0 of the pair that made it (FrameInput::step_us); 0 = unknown
    // `left` prepared for the flow search (gray, its pyramid), or null: the next pair's t0 image's.
    std::shared_ptr<const flow::DisPyramid> pyramid;
    // True when (l, r, lidar) are the pair and points it was computed from, bit for bit.
    bool matches(const cv::Mat &l, const cv::Mat &r, const SparseLidar &lidar) const;
};

// OpenCV's DIS as the matcher runs it for each direction: PRESET_MEDIUM with `o`'s finest level,
// patch size and stride, descent steps and refinement (bench_flow measures the same object).
cv::Ptr<cv::DISOpticalFlow> flow_search(const FlowSearchOptions &o);

// A stream's first frame (left, right, its t0 points `lidar`) before its pair exists: the
// disparity match_decoupled would compute for it as the pair's t0, to pass as that pair's
// t0_reuse (no motion prior, no carried points: the pair's result is that of a lone pair).
// Why: a frame arrives one frame period before its pair can start. Throws lidarflow::Error for
// bad inputs or options. Deterministic.
std::shared_ptr<DecoupledStereo> first_frame_stereo(const cv::Mat &left, const cv::Mat &right,
                                                    const SparseLidar &lidar, const MatchingOptions &opt,
                                                    const consistency::SgmOptions &sgm);

// Runs the decoupled stage 1 on the images of `in` (all one size, 8-bit gray or BGR). `sgm` are
// stage 2's SGBM settings (one disparity for both stages). `t0_reuse`, when not null and
// pixel-identical to (left0, right0) and made with the same guiding points (lidar0 when the
// stereo is guided and the LiDAR on, else none), supplies the t0 disparity. Throws lidarflow::Error for bad inputs. Deterministic.
// `camera` (all zero = unknown) is the rig at the images' resolution. `step_us` is this pair's
// t1 - t0 (0 = unknown): t0_reuse's motion prior, one step's motion, is left out (and that
// logged) when the step that made it differs by more than 25 % (a dropped frame).
// `lagged_prior`, when not null, is the motion prior instead (frames in flight: the movers of a
// pair some steps before, already carried to these t0 images); only its object_motion and
// step_us are read, under the same step check.
DecoupledResult match_decoupled(const MatchInput &in, const MatchingOptions &opt,
                                const consistency::SgmOptions &sgm, const StereoCamera &camera, bool backward,
                                const DecoupledStereo *t0_reuse = nullptr, int64_t step_us = 0,
                                const DecoupledStereo *lagged_prior = nullptr);

}  // namespace lidarflow::matching
