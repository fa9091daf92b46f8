// SPDX-License-Identifier: MIT
#include "pipeline/estimator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "consistency/consistency.hpp"
#include "core/error.hpp"
#include "core/limits.hpp"
#include "core/log.hpp"
#include "core/pixels.hpp"
#include "core/threads.hpp"
#include "lidar/binning.hpp"
#include "matching/motion_prior.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "pipeline/confidence.hpp"
#include "pipeline/resolution.hpp"

namespace lidarflow::pipeline {
namespace {

using Clock = std::chrono::steady_clock;

// The confidence's measured support (pipeline/confidence.hpp): agreement within 1 px in a 7 x 7
// box, both in pixels of the full-resolution image.
constexpr double kSupportRadius = 3.0;
constexpr double kSupportTolerance = 1.0;
constexpr float kSupportWeight = 0.2f;
// The confidence of a result whose inputs the quality checks flag (swapped, not rectified, ...).
constexpr float kFlaggedConfidenceScale = 0.25f;
// A carried LiDAR point joins a pair where its t0 stereo disparity agrees within this [px]:
// without the check 3 % of them were > 3 px off on the synthetic drives (occlusions), with it 0.2 %.
constexpr float kCarriedTolerance = 2.0f;

void report_hidden(const SparseLidar &given, const SparseLidar &kept, const char *which) {
    const size_t removed = given.points.size() - kept.points.size();
    if (removed == 0 || !log::enabled(log::Level::Info)) return;
    log::write(log::Level::Info, "visibility filter: " + std::to_string(removed) + " of " +
                                     std::to_string(given.points.size()) + " LiDAR points of " + which +
                                     " hidden from the left camera removed");
}

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The stage options as the estimator runs them: one thread count and one LiDAR switch.
interpolation::InterpolationOptions interpolation_options(const EstimatorOptions &o) {
    interpolation::InterpolationOptions io = o.interpolation;
    io.num_threads = o.threads;
    io.use_lidar = io.use_lidar && o.use_lidar;
    return io;
}

consistency::ConsistencyOptions consistency_options(const EstimatorOptions &o, int threads) {
    consistency::ConsistencyOptions co = o.consistency;
    co.threads = threads;
    co.after_sgm_field = o.keep_stage_fields;  // nobody else reads it
    return co;
}

matching::MatchingOptions matching_options(const EstimatorOptions &o, int threads) {
    matching::MatchingOptions mo = o.matching;
    mo.threads = threads;
    if (!o.use_lidar || !mo.use_lidar) {  // the im-only row of Table I: no LiDAR rule at all
        mo.use_lidar = false;
        mo.support_window = mo.const1 = mo.const2 = false;
    }
    return mo;
}

// The stages' search ranges follow the processing scale: they describe how far things move in
// the scene, so at half size half the pixels cover them (and the pyramid keeps its depth).
// Tolerances and window sizes stay (pipeline/resolution.hpp says why).
EstimatorOptions search_ranges_at_scale(const EstimatorOptions &o) {
    EstimatorOptions s = o;
    const double k = o.processing_scale;
    if (k >= 1.0) return s;
    s.matching.max_flow = std::max(1.0f, static_cast<float>(o.matching.max_flow * k));
    s.matching.max_disparity = std::max(1.0f, static_cast<float>(o.matching.max_disparity * k));
    s.matching.min_coarsest_height = std::max(8, static_cast<int>(std::lround(o.matching.min_coarsest_height * k)));
    s.consistency.sgm.num_disparities =
        std::max(16, (static_cast<int>(std::ceil(o.consistency.sgm.num_disparities * k)) + 15) / 16 * 16);
    return s;
}

// The core's own check of the accepted ranges (core/limits.hpp), whatever the entry point: the
// stages below assume them (SGM's speckle filter, for one, corrupts memory on wider images).
void check_frame(const FrameInput &f) {
    const cv::Mat *imgs[4] = {&f.left0, &f.right0, &f.left1, &f.right1};
    const char *names[4] = {"left0", "right0", "left1", "right1"};
    for (int i = 0; i < 4; ++i) {
        const cv::Mat &m = *imgs[i];
        require(!m.empty(), ErrorCode::InvalidArgument, std::string("FrameInput: ") + names[i] + " is empty");
        require(m.cols <= kMaxImageSide && m.rows <= kMaxImageSide, ErrorCode::InvalidArgument, [&] {
            return std::string("FrameInput: ") + names[i] + " is " + std::to_string(m.cols) + "x" +
                   std::to_string(m.rows) + ", larger than " + std::to_string(kMaxImageSide) + " px per side";
        });
        require(m.size() == f.left0.size(), ErrorCode::SizeMismatch,
                std::string("FrameInput: ") + names[i] + " differs in size from left0");
        require(m.type() == f.left0.type(), ErrorCode::InvalidArgument, [&] {
            return std::string("FrameInput: ") + names[i] + " has " + std::to_string(m.channels()) +
                   " channel(s), left0 " + std::to_string(f.left0.channels()) +
                   ": give the four images in one format (all gray or all colour)";
        });
    }
    if (!camera_unknown(f.camera)) {
        const std::string e = camera_range_error(f.camera);
        require(e.empty(), ErrorCode::InvalidArgument, "FrameInput: camera: " + e);
    }
    f.lidar0.validate(f.left0.cols, f.left0.rows, "FrameInput: lidar0");
    f.lidar1.validate(f.left0.cols, f.left0.rows, "FrameInput: lidar1");
}

// Idle OpenMP workers must not spin while OpenCV's threads (stage 1, the next frame) or other
// processes need the CPUs, however a call ends.
struct ReleaseWorkersAtEnd {
    ~ReleaseWorkersAtEnd() { release_openmp_workers(); }
};

// A frame's OpenMP threads: options.threads, or fewer where adaptive_threads finds busy CPUs.
int frame_threads(const EstimatorOptions &o) { return o.adaptive_threads ? threads_for_now(o.threads) : o.threads; }

// Whether processing at `size` reduces a frame of `full` (processing_scale rounds to the input).
bool reduces(cv::Size size, cv::Size full) { return size.width < full.width || size.height < full.height; }

}  // namespace

const char *stage_name(Stage s) {
    switch (s) {
    case Stage::Matching: return "matching";
    case Stage::Consistency: return "consistency";
    case Stage::Sparse: return "sparse";
    case Stage::Interpolation: return "interpolation";
    }
    return "unknown";
}

const char *ego_state_text(EgoState s) {
    switch (s) {
    case EgoState::Ok: return "fitted";
    case EgoState::NotRun: return "not fitted: the result comes from a stage before interpolation";
    case EgoState::NoCalibration: return "not metric: no stereo calibration (image-only)";
    case EgoState::TooFewInliers: return "not fitted: too few matches agree on one rigid background motion";
    case EgoState::Disabled: return "not fitted: the options turn the rigid background model off";
    }
    return "unknown";
}

Stage parse_stage(const std::string &name) {
    for (Stage s : {Stage::Matching, Stage::Consistency, Stage::Sparse, Stage::Interpolation})
        if (name == stage_name(s)) return s;
    throw Error(ErrorCode::InvalidArgument,
                "unknown stage '" + name + "' (matching, consistency, sparse, interpolation)");
}

void EstimatorOptions::validate() const {
    require(threads >= 1 && threads <= 256, ErrorCode::InvalidArgument, "threads must be in [1, 256]");
    require(last_stage >= Stage::Matching && last_stage <= Stage::Interpolation, ErrorCode::InvalidArgument,
            "last_stage out of range");
    require(frames_in_flight >= 1 && frames_in_flight <= 64, ErrorCode::InvalidArgument,
            "frames_in_flight must be in [1, 64]");
    require(lidar_cell >= 0 && lidar_cell <= 64, ErrorCode::InvalidArgument, "lidar_cell must be in [0, 64]");
    require(std::isfinite(processing_scale) && processing_scale >= 0.125 && processing_scale <= 1.0,
            ErrorCode::InvalidArgument, "processing_scale must be in [0.125, 1]");
    require(std::isfinite(upscale_edge_step) && upscale_edge_step >= 0 && upscale_edge_step <= 64,
            ErrorCode::InvalidArgument, "upscale_edge_step must be in [0, 64]");
    lidar_visibility.validate();
    matching_options(*this, threads).validate();
}

EstimatorOptions EstimatorOptions::preset(const std::string &name) {
    EstimatorOptions o;  // the field defaults are the paper's design
    if (name == "paper") return o;
    if (name == "balanced") {
        o.matching.thin_from_level = 1;  // every level below full resolution thinned
        // A coarser backward grid with a wider round-trip search (matching_options.hpp).
        o.matching.backward_grid_step = 6;
        o.consistency.fb_search_radius = 2;
        return o;
    }
    if (name == "default" || name == "fast" || name == "realtime") {
        // Stage 1 decoupled (stereo and flow searched apart) on the reduced frame.
        o.matching.method = matching::MatchMethod::Decoupled;
        o.matching.guided_stereo = true;  // the LiDAR in the stereo cost
        // The reduced frame is DIS's finest level: it searches down to it itself.
        o.matching.flow.finest_scale = 0;
        // Variational refinement smooths flow across motion boundaries, where the round-trip
        // check then cannot see the error.
        o.matching.flow.refine_iterations = 0;
        o.matching.flow.prior_track_step = 12;
        o.matching.flow.rigid_choice_radius = 1;  // the rigid prior's flow where it fits better
        // The backward field is dense: the round trip needs no search around its target.
        o.consistency.fb_search_radius = 0;
        o.interpolation.lidar_points_per_superpixel = 2;  // smaller superpixels with a dense scan
        o.interpolation.lidar_residual_radius = 3.0f;     // and its detail inside their planes
        o.matching.stream_lidar_frames = 3;  // a stream's static points of 3 earlier frames
        if (name != "realtime") {  // denser DIS patches on a larger frame
            o.processing_scale = 0.65;
            o.matching.flow.patch_size = 6;
            o.matching.flow.patch_stride = 2;
            if (name == "fast") {
                // Fewer DIS patches for time: flow detail matters most with a dense scan.
                o.matching.flow.patch_stride = 3;
                // Flat, noisy surfaces filled by the paths, not matched by their noise.
                o.matching.stereo.ternary_census = true;
                o.matching.stereo.census_threshold = 1;
            }
            // Stage 4's flow tolerance nearer the evaluator's 3 px at full size (the scaled
            // 1.95 px loses the drives' fast movers).
            o.interpolation.flow_inlier = 2.5f;
            // A dense scan's small superpixels merged back where they follow no depth boundary
            // (realtime's synthetic drives lost with it).
            o.interpolation.planar_merge_tolerance = 0.3f;
            o.interpolation.merge_unseen = true;
        } else {  // every stage at 0.55; stage 4 with fewer, larger superpixels and neighbours
            o.processing_scale = 0.55;
            o.interpolation.superpixels.region_size = 20;
            // A dense scan's superpixels at 14 px, not 10, following the guided stereo's depth as
            // well as colour (a mover before a background of its colour keeps superpixels of its
            // own); the point-less ones merge.
            o.interpolation.min_superpixel_size = 14;
            o.interpolation.superpixels.disparity_weight = 64.0f;
            o.interpolation.merge_unseen = true;
            o.interpolation.num_neighbors = 128;
            // Stage 4's tolerances are the full-size 3 px (flow) and 2 px (disparity) at 0.55.
            o.interpolation.flow_inlier = 1.65f;
            o.interpolation.disparity_inlier = 1.1f;
            // Less work where the tolerances left accuracy to spare: 4 SGM paths, 16 DIS
            // descent steps, 2 model rounds.
            o.matching.stereo.paths = 4;
            o.matching.flow.descent_iterations = 16;
            o.interpolation.iterations = 2;
            // The backward flow, which only the forward-backward check reads, on a coarser grid.
            o.matching.flow.backward_patch_stride = 4;
        }
        return o;
    }
    throw Error(ErrorCode::InvalidArgument, "unknown preset '" + name + "' (default, paper, balanced, fast, realtime)");
}

const SceneFlowField &EstimatorResult::output() const {
    switch (last_stage) {
    case Stage::Matching: return forward;
    case Stage::Consistency: return after_fb;
    case Stage::Sparse: return sparse;
    case Stage::Interpolation: return dense;
    }
    return dense;
}

Estimator::Estimator(const EstimatorOptions &options)
    : options_((options.validate(), options)), stage_options_(search_ranges_at_scale(options_)),
      interpolator_(interpolation_options(options)) {}

EstimatorResult Estimator::run(const FrameInput &frame) const { return run(frame, nullptr); }

EstimatorResult Estimator::drop_stage_fields(EstimatorResult r) const {
    if (options_.keep_stage_fields) return r;
    const SceneFlowField *const out = &r.output();
    for (SceneFlowField *f : {&r.forward, &r.backward, &r.after_sgm, &r.after_fb, &r.sparse, &r.dense})
        if (f != out) *f = SceneFlowField();
    return r;
}

SparseLidar lidar_in_use(const EstimatorOptions &o, const SparseLidar &lidar) {
    return o.use_lidar ? lidar::remove_hidden_points(lidar, o.lidar_visibility) : lidar;
}

EstimatorResult Estimator::run(const FrameInput &input, StreamCache *cache) const {
    const auto t_quality = Clock::now();  // the checks, the points in use and the reuse test included
    check_frame(input);
    ReleaseWorkersAtEnd release_at_end;
    const int threads = frame_threads(options_);
    if (threads < options_.threads && log::enabled(log::Level::Debug))
        log::write(log::Level::Debug, "this frame runs on " + std::to_string(threads) + " of " +
                                          std::to_string(options_.threads) +
                                          " threads: other processes keep the other CPUs busy (adaptive_threads)");
    // Every stage, and the LiDAR d0 restored after a scaled run, sees only the points in use.
    const FrameInput frame{input.left0,
                           input.right0,
                           input.left1,
                           input.right1,
                           lidar_in_use(options_, input.lidar0),
                           lidar_in_use(options_, input.lidar1),
                           input.camera,
                           input.calibration_size,
                           input.step_us};
    report_hidden(input.lidar0, frame.lidar0, "t0");
    report_hidden(input.lidar1, frame.lidar1, "t1");
    // The prepared first frame, or the previous pair's t1, serves only the pair whose t0 it is
    // (and is spent either way).
    std::shared_ptr<const PreparedFrame> first;
    if (cache) {
        if (cache->first_ && cache->first_->is_t0_of(frame)) first = cache->first_;
        cache->last_prepared_ = first != nullptr;
        cache->last_reused_frame_ = !first && cache->previous_t1_ && cache->previous_t1_->is_t0_of(frame);
        if (cache->last_reused_frame_) first = cache->previous_t1_;
        cache->first_.reset();
        cache->previous_t1_.reset();
    }
    quality::Report verdict = assess_inputs(frame, first && first->check ? &*first->check : nullptr, threads);
    const double quality_seconds = seconds_since(t_quality);
    EstimatorResult r;
    try {
        r = run_scaled(frame, cache, threads, first.get());
    } catch (const Error &e) {
        if (verdict.ok()) throw;
        // The inputs' fault is the likelier explanation of a stage that found nothing to work with.
        throw Error(e.code(), std::string(e.what()) + " (input quality: " + verdict.summary() + ")");
    }
    // A result from inputs flagged as wrong is less to be trusted everywhere: a gate on the
    // confidence then drops most of it.
    if (!verdict.ok())
        for (SceneFlowField *f : {&r.forward, &r.backward, &r.after_sgm, &r.after_fb, &r.sparse, &r.dense})
            if (!f->confidence.empty()) f->confidence *= kFlaggedConfidenceScale;
    r.quality = std::move(verdict);
    r.threads = threads;
    r.timings.insert(r.timings.begin(), {"input_quality", quality_seconds});
    r.total_seconds += quality_seconds;
    return r;
}

void Estimator::prepare_first(const cv::Mat &left, const cv::Mat &right, const SparseLidar &lidar,
                              StreamCache &cache) const {
    // The frame as both halves of a pair: the pair's own checks apply to it.
    check_frame(FrameInput{left, right, left, right, lidar, lidar, StereoCamera{}, {}, 0});
    ReleaseWorkersAtEnd release_at_end;
    const int threads = frame_threads(options_);
    auto first = std::make_shared<PreparedFrame>();
    first->left = left.clone();
    first->right = right.clone();
    first->lidar = lidar_in_use(options_, lidar);
    first->check = quality::check_stereo(left, right, options_.use_lidar ? &first->lidar : nullptr, threads);
    const cv::Size size = scaled_size(left.cols, left.rows, options_.processing_scale);
    if (reduces(size, left.size())) first->small = downscale_stereo(left, right, first->lidar, size, threads);
    const StereoFrame f = first->small.left.empty() ? StereoFrame{left, right, first->lidar} : first->small;
    const SparseLidar none{f.left.cols, f.left.rows, {}};
    const SparseLidar &points = options_.use_lidar ? f.lidar : none;
    // Stage 4 sees the pair's own points (a first pair carries none of earlier frames), thinned
    // as run_stages_2_to_4 thins them.
    if (options_.last_stage == Stage::Interpolation)
        first->stage4 = std::make_shared<const interpolation::ImageWork>(interpolator_.prepare_image(
            f.left, lidar::bin_points(points, options_.lidar_cell).points.size(), threads));
    const matching::MatchingOptions mo = matching_options(stage_options_, threads);
    if (options_.matching.method == matching::MatchMethod::Decoupled) {
        std::shared_ptr<matching::DecoupledStereo> s =
            matching::first_frame_stereo(f.left, f.right, points, mo, stage_options_.consistency.sgm);
        cache.clear();
        cache.stereo_t1_ = std::move(s);
    } else {
        std::shared_ptr<const matching::StereoFeatures> t1 = matching::stereo_features(f.left, f.right, mo);
        cache.clear();
        cache.t1_ = std::move(t1);
    }
    cache.first_ = std::move(first);
}

bool PreparedFrame::is_t0_of(const FrameInput &frame) const {
    return lidar.width == frame.lidar0.width && lidar.height == frame.lidar0.height &&
           lidar.points == frame.lidar0.points && pixel_identical(left, frame.left0) &&
           pixel_identical(right, frame.right0);
}

quality::Report Estimator::assess_inputs(const FrameInput &frame, const quality::StereoCheck *t0, int threads) const {
    quality::Input q{frame.left0, frame.right0, frame.left1, frame.right1,
                     options_.use_lidar ? &frame.lidar0 : nullptr, frame.calibration_size, threads};
    quality::Report r = quality::assess(q, t0);
    if (!r.ok()) log::write(log::Level::Warning, "input quality: " + r.summary());
    return r;
}

EstimatorResult Estimator::run_scaled(const FrameInput &frame, StreamCache *cache, int threads,
                                      const PreparedFrame *first) const {
    const interpolation::ImageWork *work = first ? first->stage4.get() : nullptr;
    if (options_.processing_scale >= 1.0) return drop_stage_fields(run_native(frame, cache, threads, work));
    const auto t_total = Clock::now();
    const int W = frame.left0.cols, H = frame.left0.rows;
    const cv::Size size = scaled_size(W, H, options_.processing_scale);
    if (!reduces(size, cv::Size(W, H))) {
        log::write(log::Level::Info, "processing_scale " + std::to_string(options_.processing_scale) + " leaves " +
                                         std::to_string(W) + "x" + std::to_string(H) +
                                         " at its size: the frame runs at full resolution");
        return drop_stage_fields(run_native(frame, cache, threads, work));
    }
    auto t = Clock::now();
    const StereoFrame *t0 = first && first->small.left.size() == size ? &first->small : nullptr;
    const FrameInput small = downscale_frame(frame, size, t0, threads);
    // A stream's next pair starts from this t1 frame: it keeps the frame at the processing size.
    std::shared_ptr<PreparedFrame> t1;
    if (cache && cache->lag_ == 0) {
        t1 = std::make_shared<PreparedFrame>();
        t1->left = frame.left1.clone();
        t1->right = frame.right1.clone();
        t1->lidar = frame.lidar1;
        t1->small = {small.left1, small.right1, small.lidar1};
    }
    const double t_down = seconds_since(t);
    EstimatorResult r = drop_stage_fields(run_native(small, cache, threads, work));
    if (t1) cache->previous_t1_ = std::move(t1);
    r.timings.insert(r.timings.begin(), {"downscale", t_down});
    t = Clock::now();
    const EdgeGuide edges0(small.left0, frame.left0, options_.upscale_edge_step);
    const EdgeGuide edges1(small.left1, frame.left1, r.backward.u.empty() ? 0.0f : options_.upscale_edge_step);
    for (SceneFlowField *f : {&r.forward, &r.backward, &r.after_sgm, &r.after_fb, &r.sparse, &r.dense}) {
        *f = upscale_field(*f, W, H, f == &r.backward ? &edges1 : &edges0, threads);  // empty fields stay empty
        if (options_.use_lidar && f != &r.backward) restore_lidar_d0(*f, frame.lidar0);
    }
    r.timings.push_back({"upscale", seconds_since(t)});
    r.total_seconds = seconds_since(t_total);
    return r;
}

EstimatorResult Estimator::run_native(const FrameInput &frame, StreamCache *cache, int threads,
                                      const interpolation::ImageWork *work) const {
    const auto t_total = Clock::now();
    EstimatorResult r;
    r.last_stage = options_.last_stage;
    const SparseLidar no_lidar0{frame.left0.cols, frame.left0.rows, {}};
    const SparseLidar no_lidar1{frame.left1.cols, frame.left1.rows, {}};
    const SparseLidar &lidar0 = options_.use_lidar ? frame.lidar0 : no_lidar0;
    const SparseLidar &lidar1 = options_.use_lidar ? frame.lidar1 : no_lidar1;

    if (options_.matching.method == matching::MatchMethod::Decoupled) {
        std::shared_ptr<matching::DecoupledStereo> next;
        bool tracked_motion = false;
        matching::CarriedLidar carried;
        const DisparityMap sgm = run_decoupled(frame, lidar0, lidar1, cache, threads, r, next, tracked_motion, carried);
        // A stream's earlier static points join this pair's own in stages 2-4 (the stereo keeps
        // the pair's own: its t0 disparity is the previous pair's t1 one, made with those).
        std::vector<uint8_t> age;
        const SparseLidar stage_lidar0 = matching::merge_carried(lidar0, carried, sgm, kCarriedTolerance, age);
        if (!carried.empty() && log::enabled(log::Level::Debug))
            log::write(log::Level::Debug, std::to_string(stage_lidar0.points.size() - lidar0.points.size()) + " of " +
                                              std::to_string(carried.points.points.size()) +
                                              " LiDAR points of earlier frames added to this pair's " +
                                              std::to_string(lidar0.points.size()));
        if (options_.last_stage != Stage::Matching)
            run_stages_2_to_4(frame, stage_lidar0, lidar1, sgm, threads, r, work);
        if (cache && cache->lag_ > 0) {
            // Frames in flight: this pair's movers for the pair lag_ pairs later, under the
            // conditions of the stream's own prior below.
            cache->lagged_out_.reset();
            if (tracked_motion && options_.matching.stream_prior && options_.last_stage == Stage::Interpolation) {
                auto later = std::make_shared<matching::DecoupledStereo>();
                later->object_motion =
                    matching::carry_object_motion(r.dense, r.ego, frame.camera, cache->lag_, threads);
                later->step_us = frame.step_us;
                if (!later->object_motion.empty()) cache->lagged_out_ = std::move(later);
            }
        }
        if (next) {
            // The next pair's prior, only from a final result with a calibrated background motion
            // that the pair's own tracks also found (stage 4 fits one even to a cut's matches).
            // Its static points too, under the same conditions (empty when stream_lidar_frames is 0).
            if (tracked_motion && options_.use_lidar && options_.last_stage == Stage::Interpolation)
                next->carried = matching::carry_static_points(stage_lidar0, age, r.dense, r.ego,
                                                              options_.matching.stream_lidar_frames);
            if (options_.matching.stream_prior && options_.last_stage == Stage::Interpolation) {
                if (tracked_motion)
                    next->object_motion = matching::carry_object_motion(r.dense, r.ego, frame.camera, 1, threads);
                if (next->object_motion.empty())
                    log::write(log::Level::Info, tracked_motion
                                                     ? "no motion prior for the next frame: this pair has no "
                                                       "calibrated background motion"
                                                     : "no motion prior for the next frame: this pair's tracks fit no "
                                                       "rigid motion (a cut or a frame out of order?)");
            }
            cache->stereo_t1_ = std::move(next);
        }
        r.total_seconds = seconds_since(t_total);
        return r;
    }
    // Stage 1. Descriptors are computed once and shared by both directions, and released before
    // stage 2: they are ~70 % of the peak RSS, and only the next frame needs (the cache's) t1 pair.
    {
        const matching::MatchInput mi{frame.left0, frame.right0, frame.left1, frame.right1, lidar0, lidar1};
        matching::SceneFlowMatcher matcher(mi, matching_options(stage_options_, threads), cache ? cache->t1_ : nullptr,
                                           cache ? std::move(cache->spare_) : nullptr);
        // The matcher holds the previous t1 pair when it reuses it; otherwise it is dead weight
        // now. A run that throws leaves the cache empty: nothing half-computed is reused.
        const bool had_t1 = cache && cache->t1_;
        if (cache) cache->t1_.reset();
        matching::MatchPair m;
        if (options_.last_stage == Stage::Matching)
            m.forward = matcher.run(matching::Direction::Forward);
        else
            m = matcher.run_both();
        r.timings.push_back({"features", matcher.seconds_features()});
        r.timings.push_back({"matching_forward", m.forward.seconds_matching});
        r.forward = std::move(m.forward.dense);
        if (options_.last_stage != Stage::Matching) {
            r.timings.push_back({"matching_backward", m.backward.seconds_matching});
            r.backward = std::move(m.backward.dense);
        }
        if (cache) {
            cache->t1_ = matcher.features_t1();
            cache->last_reused_ = matcher.reused_t0();
            cache->spare_ = matcher.release_t0();
            if (had_t1 && !cache->last_reused_)
                log::write(log::Level::Info,
                           "the previous frame's descriptors were not reused (its t1 images differ from this t0): "
                           "computed again");
        }
        if (options_.last_stage == Stage::Matching) {
            r.total_seconds = seconds_since(t_total);
            return r;
        }
    }
    release_openmp_workers();  // stage 2 starts with OpenCV's SGBM

    run_stages_2_to_4(frame, lidar0, lidar1, DisparityMap(), threads, r, work);
    r.total_seconds = seconds_since(t_total);
    return r;
}

DisparityMap Estimator::run_decoupled(const FrameInput &frame, const SparseLidar &lidar0, const SparseLidar &lidar1,
                                      StreamCache *cache, int threads, EstimatorResult &r,
                                      std::shared_ptr<matching::DecoupledStereo> &next,
                                      bool &tracked_motion, matching::CarriedLidar &carried) const {
    const matching::MatchInput mi{frame.left0, frame.right0, frame.left1, frame.right1, lidar0, lidar1};
    const bool both = options_.last_stage != Stage::Matching;
    const matching::MatchingOptions mo = matching_options(stage_options_, threads);
    const bool in_flight = cache && cache->lag_ > 0;
    matching::DecoupledResult m = matching::match_decoupled(
        mi, mo, stage_options_.consistency.sgm, frame.camera, both, cache ? cache->stereo_t1_.get() : nullptr,
        frame.step_us, in_flight ? cache->lagged_in_.get() : nullptr);
    if (cache && !in_flight) {
        if (cache->stereo_t1_ && !m.reused_t0)
            log::write(log::Level::Info,
                       "the previous frame's stereo disparity was not reused (its t1 images differ from this t0): "
                       "computed again");
        cache->last_reused_ = m.reused_t0;
        if (m.stream_continues) carried = cache->stereo_t1_->carried;  // empty when stream_lidar_frames is 0
        cache->stereo_t1_.reset();
        next = std::make_shared<matching::DecoupledStereo>();
        next->left = frame.left1.clone();
        next->right = frame.right1.clone();
        next->lidar = m.guide1;
        next->disparity = m.sgm1;
        next->pyramid = m.pyramid1;
        next->step_us = frame.step_us;
    }
    tracked_motion = m.tracked_motion;
    r.timings.push_back({"matching_stereo", m.seconds_stereo});
    r.timings.push_back({"matching_flow", m.seconds_flow});
    r.forward = std::move(m.forward);
    if (both) r.backward = std::move(m.backward);
    return m.sgm0;
}

void Estimator::run_stages_2_to_4(const FrameInput &frame, const SparseLidar &all0, const SparseLidar &all1,
                                  const DisparityMap &sgm, int threads, EstimatorResult &r,
                                  const interpolation::ImageWork *work) const {
    // Stages 2-4 see the points thinned to lidar_cell (every point when it is off).
    const SparseLidar lidar0 = lidar::bin_points(all0, options_.lidar_cell);
    const SparseLidar lidar1 = lidar::bin_points(all1, options_.lidar_cell);
    // Stages 2-3.
    auto t = Clock::now();
    consistency::ConsistencyResult c =
        sgm.empty() ? consistency::run_consistency(r.forward, r.backward, frame.left0, frame.right0, lidar0,
                                                   consistency_options(stage_options_, threads))
                    : consistency::run_consistency(r.forward, r.backward, sgm, lidar0,
                                                   consistency_options(stage_options_, threads));
    r.after_sgm = std::move(c.after_sgm);
    r.after_fb = std::move(c.after_fb);
    r.sparse = std::move(c.sparse);
    if (sgm.empty()) r.timings.push_back({"sgm", c.seconds.sgm});
    r.timings.push_back({"consistency", seconds_since(t) - c.seconds.sgm - c.seconds.sparsify});
    r.timings.push_back({"sparsify", c.seconds.sparsify});
    if (options_.last_stage <= Stage::Sparse) return;

    release_openmp_workers();  // stage 4 starts with OpenCV's own parallel filters
    // Stage 4 reads only the sparse matches and the SGM disparity: fields nobody keeps are
    // released first, so that stage 4's own memory reuses theirs instead of adding to it.
    // Stage 1's forward measurement stays for the confidence (its u, v, d0 and valid planes).
    const SceneFlowField measured{r.forward.u, r.forward.v, r.forward.d0, cv::Mat1f(), r.forward.valid, cv::Mat1f()};
    if (!options_.keep_stage_fields)
        for (SceneFlowField *f : {&r.forward, &r.backward, &r.after_sgm, &r.after_fb}) *f = SceneFlowField();

    // Stage 4.
    t = Clock::now();
    interpolation::InterpolationResult ir =
        interpolator_.run(r.sparse, lidar0, frame.left0, c.sgm, frame.camera, lidar1, threads, work);
    r.dense = std::move(ir.dense);
    if (log::enabled(log::Level::Debug)) {
        const interpolation::InterpolationTimings &it = ir.timings;
        char line[256];
        std::snprintf(line, sizeof line,
                      "stage 4: %d superpixels of %d px; seeds %.1f ms, edges %.1f ms, superpixels %.1f ms, "
                      "neighbours %.1f ms, models %.1f ms, output %.1f ms; all %.1f ms",
                      ir.num_superpixels, ir.superpixel_size, 1e3 * it.seeds_s, 1e3 * it.edges_s,
                      1e3 * it.superpixels_s, 1e3 * it.geodesic_s, 1e3 * it.models_s, 1e3 * it.output_s,
                      1e3 * it.total_s);
        log::write(log::Level::Debug, line);
    }
    const double k = std::min(1.0, options_.processing_scale);
    add_measured_support(r.dense, measured, std::max(1, static_cast<int>(std::lround(kSupportRadius * k))),
                         static_cast<float>(kSupportTolerance * k), kSupportWeight, threads);
    r.ego = ir.ego;
    const interpolation::InterpolationOptions &io = interpolator_.options();
    r.ego_state = r.ego.valid && r.ego.calibrated      ? EgoState::Ok
                  : !io.ego_motion || !io.rigid_ego_motion ? EgoState::Disabled
                  : !frame.camera.valid()                  ? EgoState::NoCalibration
                                                           : EgoState::TooFewInliers;
    r.timings.push_back({"interpolation", seconds_since(t)});
}

bool lagged_prior_in_pace(double t0, double t1, double later_t0, int lag) {
    const double expected = (lag - 1) * (t1 - t0);
    return std::abs((later_t0 - t1) - expected) <= 0.25 * expected;
}

}  // namespace lidarflow::pipeline
