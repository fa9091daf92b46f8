// SPDX-License-Identifier: MIT
#pragma once
// What the opaque C handles are. Private to capi/.
#include <atomic>
#include <cstdint>
#include <deque>
#include <exception>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "core/ordered_pool.hpp"
#include "guard.hpp"
#include "io/rectify.hpp"
#include "io/rig.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/option_keys.hpp"

struct lf_options {
    lidarflow::pipeline::OptionValues values;
    std::string error;  // lf_options_last_error
};

namespace lidarflow::capi {

// The calibration as the estimator keeps it.
struct Calibration {
    StereoCamera camera;  // the rectified pair (= rig.rect.camera)
    bool has_lidar_to_camera = false;
    cv::Matx44d lidar_to_camera = cv::Matx44d::eye();
    io::Rig rig;  // image size (rig.rect.image_size, 0x0 = unknown) and, when rig.rectify, the raw cameras
};

// One pushed frame, owned by the estimator.
struct Frame {
    int64_t timestamp_us = 0;
    cv::Mat left, right;  // 8-bit gray or BGR
    SparseLidar lidar;    // in `left`
};

// The latest result: the output field of the last stage plus what describes it.
struct Result {
    SceneFlowField field;  // continuous planes; confidence always present
    pipeline::Stage stage = pipeline::Stage::Interpolation;
    int64_t t0_us = 0, t1_us = 0;
    std::vector<pipeline::StageTime> timings;
    double total_seconds = 0;
    motion::EgoMotion ego;  // stage 4's background motion (pipeline::EstimatorResult::ego)
    pipeline::EgoState ego_state = pipeline::EgoState::NotRun;
    quality::Report quality;  // of the inputs (lf_get_quality)
    bool rectified = false;   // the pair was rectified inside (lf_result_info_t::rectified)
    // Frames in flight: the pair's place in its sequence (0 = the first pair after lf_reset)
    // and its movers for the pair frames_in_flight pairs later (StreamCache::set_in_flight).
    int64_t pair_index = 0;
    std::shared_ptr<const matching::DecoupledStereo> prior_for_later;
};

// A handed-over pair's motion prior for the pair frames_in_flight after it, and its frames.
struct HandedPrior {
    int64_t pair_index = 0;
    int64_t t0_us = 0, t1_us = 0;
    std::shared_ptr<const matching::DecoupledStereo> prior;
};

}  // namespace lidarflow::capi

struct lf_estimator {
    lf_estimator(const lidarflow::pipeline::EstimatorOptions &options, const lidarflow::capi::Calibration &c)
        : estimator(options), calibration(c) {}

    lidarflow::pipeline::Estimator estimator;
    lidarflow::capi::Calibration calibration;
    bool strict_input = false;   // option "input.strict"
    bool size_warned = false;    // the calibration-size warning was logged (once per handle)
    // Tables for the pushed size when calibration.rig.rectify; made at the first push.
    std::shared_ptr<const lidarflow::io::Rectifier> rectifier;
    // Null before the first frame / after reset; shared with the pairs in flight that read it.
    std::shared_ptr<const lidarflow::capi::Frame> previous;
    std::unique_ptr<lidarflow::capi::Result> result;   // null until two frames were pushed
    // Frames in flight: why the pair handed over last has no result (the readers report it).
    std::exception_ptr pair_error;
    // The newer pair's descriptors, reused by the next push (frame k's t1 is frame k+1's t0).
    lidarflow::pipeline::StreamCache stream;
    mutable std::string error;                          // lf_last_error
    // Set while lf_push_frame or lf_reset runs: one of them called from inside another on the
    // same handle (its log callback, which may run on any of the call's threads) is refused
    // instead of freeing the frame the outer call is reading.
    std::atomic<bool> busy{false};
    // Frames in flight: pairs started since lf_reset, and the motion priors of pairs handed over
    // that a pair not yet started may take (pair i's serves pair i + frames_in_flight), oldest
    // first. Kept by index, so an lf_flush in mid-stream changes no later pair.
    int64_t pairs_started = 0;
    std::deque<lidarflow::capi::HandedPrior> priors;
    // With "frames_in_flight" > 1: the pairs being computed, oldest first. Declared last: it is
    // destroyed (waiting for its jobs, which read the members above) first.
    std::unique_ptr<lidarflow::OrderedPool<std::unique_ptr<lidarflow::capi::Result>>> pool;
};

namespace lidarflow::capi {

// The handle whose pair the calling thread computes (a frame worker's log callback runs there),
// else null.
inline thread_local const lf_estimator_t *pair_owner = nullptr;

// Where a call's error goes: the handle's message, except from one of the handle's frame
// workers, whose message stays in lf_last_error(NULL) (the handle's belongs to its owner's thread).
inline ErrorSink sink_of(lf_estimator_t *h) { return ErrorSink(h && pair_owner != h ? &h->error : nullptr); }

}  // namespace lidarflow::capi
