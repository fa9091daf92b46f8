// SPDX-License-Identifier: MIT
#pragma once
// The complete LiDAR-Flow estimator: stage 1 matching (both directions) -> stage 2 consistency
// -> stage 3 sparsification -> stage 4 interpolation. It owns the options of every stage,
// can stop after any stage (for Table I and ablations), and returns every intermediate field
// with per-stage timings. This is what the C ABI and the CLI wrap.
#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "consistency/options.hpp"
#include "core/camera.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "core/threads.hpp"
#include "interpolation/interpolator.hpp"
#include "lidar/visibility_filter.hpp"
#include "matching/decoupled_matcher.hpp"
#include "matching/matching_options.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "quality/input_quality.hpp"

namespace lidarflow::pipeline {

enum class Stage { Matching = 1, Consistency = 2, Sparse = 3, Interpolation = 4 };

// "matching", "consistency", "sparse", "interpolation".
const char *stage_name(Stage s);
// Inverse of stage_name; throws Error(InvalidArgument) for an unknown name.
Stage parse_stage(const std::string &name);

struct EstimatorOptions {
    // Master LiDAR switch. false = the image-only (SceneFlowFields-style) pipeline: the
    // matcher runs im-only, stages 2-4 get no LiDAR. LiDAR inputs are then ignored.
    bool use_lidar = true;
    Stage last_stage = Stage::Interpolation;
    // OpenMP threads for every stage (num_threads clauses; never global); default: the usable CPUs.
    int threads = default_threads();
    // Each frame uses at most the CPUs other processes leave idle at its start (at least one;
    // core/threads.hpp). Results never depend on it; false: always `threads`.
    bool adaptive_threads = true;
    // Every stage runs on the frame resized by this factor, in [0.125, 1]; the results are
    // brought back to the input size (pipeline/resolution.hpp). 1 = full resolution. The
    // search ranges (matching.max_flow, max_disparity, min_coarsest_height and the SGM range)
    // are taken at full resolution and scaled with it; the other pixel options are not.
    double processing_scale = 1.0;
    // Bringing the results back from processing_scale < 1: where d0, u or v jumps by more than
    // this [px of the processing frame] between the four nearest pixels, a pixel takes the one
    // nearest in intensity rather than their blend (pipeline/resolution.hpp); 0 = always blend.
    float upscale_edge_step = 3.0f;
    // Whether EstimatorResult holds every stage's field, or only output()'s (the others stay
    // empty, and are not brought back to full resolution at processing_scale < 1: that took
    // 0.12-0.14 s of the `fast` preset's ~0.8 s per KITTI pair for five fields nobody read).
    // The C ABI handle (and so the bridge and Python) reads only the output and sets this to
    // false.
    bool keep_stage_fields = true;
    // A frame whose size differs from the calibration's (when the calibration knows it) is
    // refused instead of logged as a warning once. Checked by the callers that hold the
    // calibration (the C ABI handle, `lidarflow run`) with io::image_size_mismatch.
    bool strict_input = false;
    // Pairs one stream computes at once, in [1, 64] (docs/ARCHITECTURE.md, "Frames in flight").
    // Above 1 the callers that stream (the C ABI handle, `lidarflow sequence`) run the pairs on
    // an OrderedPool, each with a StreamCache of its own set by StreamCache::set_in_flight (the
    // motion prior of the pair frames_in_flight before), each frame on per_frame_threads()
    // threads; Estimator::run itself does not read it.
    int frames_in_flight = 1;
    // threads shared by the frames in flight: threads / frames_in_flight, at least 1.
    int per_frame_threads() const { return std::max(1, threads / frames_in_flight); }

    // LiDAR points the camera cannot see (behind an object's edge, seen past it from the
    // LiDAR's position) are removed from lidar0 and lidar1 before every stage, at the input's
    // resolution (lidar/visibility_filter.hpp).
    lidar::VisibilityFilterOptions lidar_visibility;
    // Stages 2-4 see at most one LiDAR point per lidar_cell x lidar_cell px of the processing
    // frame (lidar/binning.hpp; <= 1 = every point); stage 1 always reads every point. Their
    // cost then does not grow with a dense scan's ~20k points.
    int lidar_cell = 0;
    matching::MatchingOptions matching;
    consistency::ConsistencyOptions consistency;
    interpolation::InterpolationOptions interpolation;

    // Throws Error(InvalidArgument) naming the first bad field.
    void validate() const;

    // Named speed/accuracy trade-offs. The field defaults above are the paper's design; the
    // presets (the README's preset table has the measured curve):
    //  "paper"    the paper's design (PatchMatch stage 1 with the LiDAR), the field defaults;
    //  "balanced" the paper's design with every matcher level below full resolution thinned
    //             (thin_from_level 1), the backward direction on a 6 px grid (radius 2);
    //  "default"  the decoupled stage 1 (LiDAR-guided SGM + DIS from the rigid prior, t1
    //             stereo guided by the carried scan) at 0.65 size, DIS patches of 6 px every
    //             2 px, superpixels sized by the LiDAR's density;
    //  "fast"     "default" with DIS patches every 3 px (a fifth less time) and the ternary
    //             census with threshold 1 (flat, noisy surfaces filled by the paths);
    //  "realtime" the decoupled stage 1 at 0.55 size, stage 4 with 20 px superpixels and 128
    //             neighbours.
    // Throws Error(InvalidArgument) for another name.
    static EstimatorOptions preset(const std::string &name);
};

// The points of `lidar` that the estimator's stages use under `o`: those the visibility filter
// keeps (lidar/visibility_filter.hpp), or all of them when it is off or LiDAR is not used.
// Throws like lidar::remove_hidden_points.
SparseLidar lidar_in_use(const EstimatorOptions &o, const SparseLidar &lidar);

// Caller-owned views, only read during run().
struct FrameInput {
    cv::Mat left0, right0, left1, right1;  // rectified, 8-bit gray or BGR, all one size
    SparseLidar lidar0;  // D_l^0 in I_l^0 (may have no points)
    SparseLidar lidar1;  // D_l^1 in I_l^1 (may have no points, e.g. a real scan only at t0)
    StereoCamera camera; // the rectified rig; all zero (default) = unknown (calibration-free
                         // models); anything else must lie in the ranges of core/limits.hpp
    cv::Size calibration_size;  // the image size `camera` describes; 0 = unknown (not checked)
    // t1 - t0 [us] of a stream's pair; 0 = unknown. A stream keeps its motion prior only from a
    // pair of about the same step (a dropped frame doubles it).
    int64_t step_us = 0;
};

// One stereo pair (a frame) and its points.
struct StereoFrame {
    cv::Mat left, right;
    SparseLidar lidar;
};

// Why EstimatorResult::ego is or is not the metric ego-motion (values of the C ABI's
// lf_ego_state_t).
enum class EgoState { Ok = 0, NotRun = 1, NoCalibration = 2, TooFewInliers = 3, Disabled = 4 };
const char *ego_state_text(EgoState s);

struct StageTime {
    std::string name;
    double seconds = 0;
};

struct EstimatorResult {
    Stage last_stage = Stage::Interpolation;
    SceneFlowField forward;   // stage 1, reference I_l^0 (dense)
    SceneFlowField backward;  // stage 1, reference I_l^1 (dense; empty if not needed)
    SceneFlowField after_sgm; // stage 2a + clustering (Table I "Disp+LiDAR")
    SceneFlowField after_fb;  // stage 2b + clustering (Table I "disp+LiDAR & backward+LiDAR")
    SceneFlowField sparse;    // stage 3 (Table I "Spars+LiDAR")
    SceneFlowField dense;     // stage 4 (the final result)
    // The output of last_stage: one of the fields above.
    const SceneFlowField &output() const;
    SceneFlowField &output() { return const_cast<SceneFlowField &>(static_cast<const EstimatorResult &>(*this).output()); }
    // Stage 4's background model (motion::EgoMotion), kept as fitted: the rigid motion
    // of the static scene t0 -> t1 when the camera was known (calibrated = true), its R, t in
    // metres and so the same at any processing_scale. valid = false: stage 4 did not run, the
    // ego-motion model is off, or too few matches agree on one motion.
    motion::EgoMotion ego;
    EgoState ego_state = EgoState::NotRun;  // Ok exactly when ego is valid and calibrated

    // Whether the inputs look like what the estimator assumes (quality/input_quality.hpp).
    quality::Report quality;

    std::vector<StageTime> timings;  // in execution order
    double total_seconds = 0;
    // The OpenMP threads the frame ran with: options.threads, or fewer where adaptive_threads
    // left busy CPUs to other processes (core/threads.hpp). Results never depend on it.
    int threads = 0;
};

// What a stream of frames keeps between consecutive Estimator::run calls: the newer stereo
// pair's full-resolution descriptors (frame k's t1 images are frame k+1's t0 images; the coarse
// levels are recomputed, see matching::StereoFeatures). Used only when the
// next frame's left0/right0 are pixel-identical to the previous left1/right1, so a wrong or
// stale cache costs time, never accuracy. One per stream; not safe for concurrent runs.
//
// It also keeps the buffers of the pair the last frame no longer needed (its t0) and writes the
// next frame's t1 descriptors into them: a stream then stops faulting in and clearing ~120 MB
// of fresh pages per KITTI frame, at the price of holding them between frames.
// Frames in flight: whether the motion prior of the pair t0 -> t1 may serve the pair `lag`
// after it, which starts at later_t0 (any one time unit): the frames since kept that pair's
// pace within 25 %, as the prior's carry over lag steps assumes (a dropped frame breaks it).
bool lagged_prior_in_pace(double t0, double t1, double later_t0, int lag);

// What Estimator::prepare_first keeps of a stream's first frame for its pair besides stage 1's
// part: the frame itself (copies, to know it again as the pair's t0), its stereo checks, its
// images and points at the processing size, and stage 4's work on its left image. A stream's
// run keeps the same of its t1 frame for the next pair, without the checks and stage 4's work
// (computed for a frame only as a t0).
struct PreparedFrame {
    cv::Mat left, right;
    SparseLidar lidar;  // the points in use (lidar_in_use)
    std::optional<quality::StereoCheck> check;
    StereoFrame small;  // at the processing size; empty images when the frame runs at its own
    std::shared_ptr<const interpolation::ImageWork> stage4;  // null when the run stops before stage 4
    // Whether `frame`'s t0 images and points (those in use) are this frame's.
    bool is_t0_of(const FrameInput &frame) const;
};

class StreamCache {
public:
    void clear() {
        first_.reset();
        previous_t1_.reset();
        t1_.reset();
        spare_.reset();
        stereo_t1_.reset();
        lag_ = 0;
        lagged_in_.reset();
        lagged_out_.reset();
    }
    // Whether the last run through this cache reused the previous frame's descriptors.
    bool last_reused() const { return last_reused_; }
    // Whether the last run through this cache took prepare_first's frame as its t0.
    bool last_prepared() const { return last_prepared_; }
    // Whether the last run took the previous run's t1 frame at the processing size as its t0's.
    bool last_reused_frame() const { return last_reused_frame_; }

    // Frames in flight (docs/ARCHITECTURE.md): a pool computes pair k while pairs k-lag+1 ..
    // k-1 are still running, so pair k's motion prior comes from pair k-lag, carried lag steps.
    // A cache set so (one per pair, fresh) reuses nothing else; run() then reads `prior` (pair
    // k-lag's prior_for_later(), or null) and leaves this pair's own movers carried lag steps
    // ahead in prior_for_later() (null when it has none: no calibrated background motion, a
    // cut, stream_prior off, another last stage).
    void set_in_flight(int lag, std::shared_ptr<const matching::DecoupledStereo> prior) {
        lag_ = lag;
        lagged_in_ = std::move(prior);
    }
    std::shared_ptr<const matching::DecoupledStereo> prior_for_later() const { return lagged_out_; }

private:
    friend class Estimator;
    int lag_ = 0;
    std::shared_ptr<const matching::DecoupledStereo> lagged_in_, lagged_out_;
    std::shared_ptr<const matching::StereoFeatures> t1_;
    std::shared_ptr<matching::StereoFeatures> spare_;  // storage for the next t1 pair
    std::shared_ptr<const matching::DecoupledStereo> stereo_t1_;  // decoupled design: t1 disparity
    std::shared_ptr<const PreparedFrame> first_;  // prepare_first's, until the next run
    std::shared_ptr<const PreparedFrame> previous_t1_;  // the last run's t1 frame, until the next run
    bool last_reused_ = false;
    bool last_prepared_ = false;
    bool last_reused_frame_ = false;
};

class Estimator {
public:
    // Validates and copies the options. Throws Error(InvalidArgument) (bad options) or
    // Error(Io/Format) (an SED edge model that cannot be loaded).
    explicit Estimator(const EstimatorOptions &options);

    // Runs the stages up to options.last_stage. Throws Error(SizeMismatch / InvalidArgument)
    // for bad inputs, among them inputs outside the ranges of core/limits.hpp (image sides,
    // LiDAR disparities, a camera that is neither all-zero "unknown" nor in range); the
    // estimator stays usable. Const and thread-safe: distinct threads may
    // run distinct frames on one Estimator.
    EstimatorResult run(const FrameInput &frame) const;
    // Same, for a sequence: reuses and then updates *cache (see StreamCache); cache may be null.
    EstimatorResult run(const FrameInput &frame, StreamCache *cache) const;

    // A stream's first frame (after a new cache or clear()), before its pair exists: computes
    // into *cache what the pair's run(frame, cache) would compute of that frame as its t0 (the
    // decoupled design's t0 disparity, the paper design's t0 descriptors; the input checks of
    // the frame's stereo pair, its images at the processing size and stage 4's edges and
    // superpixels of its left image), which that run then takes as a previous frame's when its
    // t0 is this frame: the pair's result stays bit for bit that of run() alone, and
    // a later frame's inputs that differ only cost the reuse. Why: a frame arrives one frame
    // period before its pair can start, so a lone pair's latency loses that part.
    // Throws lidarflow::Error for bad images or points (the cache is then left unchanged).
    // Not thread-safe on one cache; distinct caches may be prepared concurrently.
    void prepare_first(const cv::Mat &left, const cv::Mat &right, const SparseLidar &lidar, StreamCache &cache) const;

    const EstimatorOptions &options() const { return options_; }

private:
    // The input checks of quality/input_quality.hpp, logged as a warning when one fails.
    // t0: the checks of the frame's t0 pair computed ahead, or null.
    quality::Report assess_inputs(const FrameInput &frame, const quality::StereoCheck *t0, int threads) const;
    // run() after the input checks: at processing_scale, results brought back to the input size.
    // first: the prepared frame that is this pair's t0, or null.
    EstimatorResult run_scaled(const FrameInput &frame, StreamCache *cache, int threads,
                               const PreparedFrame *first) const;
    // threads: this frame's OpenMP threads (core/threads.hpp). work: stage 4's work on
    // frame.left0 computed ahead, or null.
    EstimatorResult run_native(const FrameInput &frame, StreamCache *cache, int threads,
                               const interpolation::ImageWork *work) const;
    // Stages 2-4 on stage 1's fields (r.forward, r.backward); `sgm` is stage 2's reference
    // disparity, or empty to compute it here.
    void run_stages_2_to_4(const FrameInput &frame, const SparseLidar &lidar0, const SparseLidar &lidar1,
                           const DisparityMap &sgm, int threads, EstimatorResult &r,
                           const interpolation::ImageWork *work) const;
    // Stage 1 of the decoupled design (matching/decoupled_matcher.hpp); returns stage 2's SGM.
    // With a cache, `next` is the t1 pair's stereo, which the caller stores in the cache once
    // the pair's result is complete; `tracked_motion` says whether the pair's tracks fit a
    // rigid background motion (DecoupledResult::tracked_motion).
    DisparityMap run_decoupled(const FrameInput &frame, const SparseLidar &lidar0, const SparseLidar &lidar1,
                               StreamCache *cache, int threads, EstimatorResult &r,
                               std::shared_ptr<matching::DecoupledStereo> &next, bool &tracked_motion,
                               matching::CarriedLidar &carried) const;
    // Empties every field but output() unless options_.keep_stage_fields.
    EstimatorResult drop_stage_fields(EstimatorResult r) const;

    EstimatorOptions options_;
    EstimatorOptions stage_options_;  // options_ with search ranges at processing_scale
    interpolation::RobustInterpolator interpolator_;
};

}  // namespace lidarflow::pipeline
