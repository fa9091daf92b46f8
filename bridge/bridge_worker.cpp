// SPDX-License-Identifier: MIT
// The worker thread: takes queued frames, pairs them with LiDAR, runs the estimator and puts
// the encoded results in the outbox.
#include <algorithm>
#include <chrono>
#include <cinttypes>

#include "bridge_core.hpp"
#include "bridge_frame.hpp"

namespace lidarflow::bridge {
namespace {

// The one-line form of a result's quality: "ok" or "NAME[, NAME...] (reason)".
std::string quality_summary(uint32_t flags, const char *reason) {
    if (flags == 0) return "ok";
    std::string names;
    for (uint32_t bit = 1; bit != 0; bit <<= 1)
        if (flags & bit) names += (names.empty() ? "" : ", ") + std::string(lf_quality_name(bit));
    return names + " (" + reason + ")";
}

bool same_calibration(const lf_calibration_t &a, const lf_calibration_t &b) {
    return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.baseline == b.baseline;
}

bool carries_transform(const lf_calibration_t &cal, const double *T) {
    return cal.has_lidar_to_camera == 1 && std::equal(T, T + 16, cal.lidar_to_camera);
}

}  // namespace

void Bridge::worker_loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        cv_.wait(lock, [this] { return stop_worker_ || !queue_.empty(); });
        if (stop_worker_) return;
        std::unique_ptr<Frame> frame = std::move(queue_.front());
        queue_.pop_front();
        counters_.queue_depth = static_cast<int32_t>(queue_.size());
        counters_.busy = true;
        // A sweep may arrive after its frame; wait a little for it, but only when a LiDAR
        // stream exists at all (image-only setups would pay the wait on every frame).
        const int64_t utime = frame->stereo.msg().utime;
        std::shared_ptr<const LidarSweep> sweep = pairing_.lidar_for(utime);
        const auto deadline = std::chrono::steady_clock::time_point(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            std::chrono::duration<double>(frame->received_seconds + config_.lidar_wait_ms / 1000.0)));
        while (!sweep && !stop_worker_ && counters_.lidar_received > 0 &&
               cv_.wait_until(lock, deadline) != std::cv_status::timeout)
            sweep = pairing_.lidar_for(utime);
        if (!sweep) sweep = pairing_.lidar_for(utime);
        if (stop_worker_) {
            frame->count_in(counters_.dropped_shutdown);
            counters_.busy = false;
            return;
        }
        lock.unlock();
        process(*frame, sweep);
        frame.reset();
        lock.lock();
        counters_.busy = false;
        wake();
    }
}

void Bridge::process(Frame &frame, std::shared_ptr<const LidarSweep> sweep) {
    const lidarflow_stereo_t &m = frame.stereo.msg();
    auto drop = [&](const std::string &why) {
        std::lock_guard<std::mutex> lock(mutex_);
        frame.count_in(counters_.dropped_estimator_error);
        counters_.last_error = why;
        log("stereo frame %" PRId64 " dropped: %s", m.utime, why.c_str());
    };
    const lf_image_t left = frame.stereo.left(), right = frame.stereo.right();
    // A new sequence or another image size / format starts over: never pair across a cut.
    // --shard: a pair only of consecutive frames; a frame that is just the next pair's t0
    // starts over, so that no one else's pair is computed. (Before the estimator is chosen: a
    // reset estimator holds no frame and may take a new transform for free.)
    const bool shard_cut = config_.shard_count > 1 && (frame.t0_only || static_cast<uint64_t>(frame.index) - 1 != static_cast<uint64_t>(prev_index_));
    if (estimator_has_frame_ && (shard_cut || m.sequence != prev_sequence_ || left.width != prev_width_ ||
                                 left.height != prev_height_ || left.format != prev_format_)) {
        lf_reset(estimator_);
        estimator_has_frame_ = false;
    }
    // The estimator's calibration carries the transform of LiDAR-frame sweeps, so that it moves
    // their points itself (LidarSweep). It takes a new transform only while it holds no frame:
    // replacing it then costs nothing, while a pair in progress would be lost.
    const double *sweep_T = sweep && sweep->in_lidar_frame ? sweep->lidar_to_camera : nullptr;
    const bool new_camera = !estimator_ || !same_calibration(estimator_calibration_, frame.calibration);
    if (new_camera && estimator_has_frame_) {
        // The pair (previous frame, this one) cannot be computed across a camera change.
        std::lock_guard<std::mutex> lock(mutex_);
        frame.count_in(counters_.pairs_lost_calibration_change);
        log("stereo frame %" PRId64 ": the calibration changed since frame %" PRId64 ", their pair is lost", m.utime,
            prev_utime_);
    }
    if (new_camera || (sweep_T && !estimator_has_frame_ && !carries_transform(estimator_calibration_, sweep_T))) {
        lf_calibration_t cal = frame.calibration;
        const double *T = sweep_T ? sweep_T
                          : estimator_ && estimator_calibration_.has_lidar_to_camera ? estimator_calibration_.lidar_to_camera
                          : config_.have_lidar_to_camera ? config_.lidar_to_camera
                                                         : nullptr;
        if (T) {
            std::copy(T, T + 16, cal.lidar_to_camera);
            cal.has_lidar_to_camera = 1;
        }
        lf_destroy(estimator_);
        estimator_ = nullptr;
        estimator_has_frame_ = false;
        if (lf_create(options_, &cal, &estimator_) != LF_OK) {
            drop(std::string("estimator creation failed: ") + lf_last_error(nullptr));
            return;
        }
        estimator_calibration_ = cal;
    }
    lf_lidar_t lidar{};
    if (sweep) lidar = sweep_T && carries_transform(estimator_calibration_, sweep_T) ? sweep->lidar_frame_view() : sweep->view();
    if (sweep_T && lidar.kind != LF_LIDAR_POINTS_LIDAR) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (counters_.lidar_moved_by_bridge++ == 0)
            log("LiDAR sweep %" PRId64 ": its transform changed within a pair; the bridge moves such points itself "
                "(one float cast) until the next sequence (logged once)",
                sweep->utime);
    }
    bool with_lidar = static_cast<bool>(sweep);
    int32_t st = lf_push_frame(estimator_, m.utime, &left, &right, with_lidar ? &lidar : nullptr);
    if (st != LF_OK && with_lidar) {
        const std::string why = lf_last_error(estimator_);
        if (lf_push_frame(estimator_, m.utime, &left, &right, nullptr) == LF_OK) {
            st = LF_OK;
            with_lidar = false;
            std::lock_guard<std::mutex> lock(mutex_);
            frame.count_in(counters_.lidar_rejected);
            counters_.last_error = "lidar: " + why;
            log("LiDAR sweep %" PRId64 " rejected by the estimator (%s): frame %" PRId64 " processed without LiDAR",
                sweep->utime, why.c_str(), m.utime);
        }
    }
    if (st != LF_OK) {
        drop(lf_last_error(estimator_));
        return;
    }
    const bool had_previous = estimator_has_frame_;
    const bool previous_lidar = prev_had_lidar_, previous_warm_up = prev_warm_up_;
    const int64_t previous_lidar_utime = prev_lidar_utime_;
    estimator_has_frame_ = true;
    prev_sequence_ = m.sequence;
    prev_index_ = frame.index;
    prev_utime_ = m.utime;
    prev_width_ = left.width;
    prev_height_ = left.height;
    prev_format_ = left.format;
    prev_had_lidar_ = with_lidar;
    prev_warm_up_ = frame.warm_up;
    prev_lidar_utime_ = with_lidar ? sweep->utime : 0;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (frame.warm_up) {
            ++counters_.warm_up_fed;
        } else {
            ++counters_.stereo_processed;
            counters_.frames_with_lidar += with_lidar ? 1 : 0;
        }
    }
    if (!had_previous || !lf_has_result(estimator_)) return;
    if (previous_warm_up) {
        // Computed for the stream's priors only (the pair ends at the part's first frame or before).
        std::lock_guard<std::mutex> lock(mutex_);
        ++counters_.warm_up_pairs;
        return;
    }

    lf_result_info_t info;
    lf_result_info_init(&info);
    lf_result_views_t views;
    lf_result_views_init(&views);
    FlowMessage flow;
    std::string err;
    if (lf_get_result_info(estimator_, &info) != LF_OK || lf_get_result_views(estimator_, &views) != LF_OK) {
        err = lf_last_error(estimator_);
    } else if (encode_flow(views, config_.encoding, config_.step, flow, &err)) {
        lidarflow_scene_flow_t &h = flow.header;
        h.utime = info.t1_us;
        h.utime0 = info.t0_us;
        h.sequence = m.sequence;
        h.lidar_flags = static_cast<int8_t>((previous_lidar ? LIDARFLOW_SCENE_FLOW_T_LIDAR_T0 : 0) |
                                            (with_lidar ? LIDARFLOW_SCENE_FLOW_T_LIDAR_T1 : 0));
        h.lidar_utime0 = previous_lidar ? previous_lidar_utime : 0;
        h.lidar_utime1 = with_lidar ? sweep->utime : 0;
        h.last_stage = static_cast<int8_t>(info.last_stage);
        h.compute_seconds = static_cast<float>(info.total_seconds);
        lidarflow_scene_flow_t msg = flow.message();
        std::vector<uint8_t> bytes = encode_scene_flow(msg);
        lf_ego_motion_t ego;
        lf_ego_motion_init(&ego);
        std::vector<uint8_t> ego_bytes;
        if (lf_get_ego_motion(estimator_, &ego) == LF_OK) {
            lidarflow_ego_motion_t em = ego_motion_message(ego, info.t1_us, info.t0_us, m.sequence);
            ego_bytes = encode_ego_motion(em);
        }
        uint32_t quality = 0;
        const char *reason = "";
        std::vector<uint8_t> quality_bytes;
        if (lf_get_quality(estimator_, &quality, &reason) == LF_OK)
            quality_bytes = encode_quality(info.t1_us, info.t0_us, m.sequence, quality, reason);
        if (bytes.empty() || ego_bytes.empty() || quality_bytes.empty()) {
            err = bytes.empty() ? "encoding the scene flow failed"
                  : ego_bytes.empty() ? "encoding the ego-motion failed"
                                      : "encoding the input quality failed";
        } else {
            std::lock_guard<std::mutex> lock(mutex_);
            if (quality != 0)
                log("result of frame %" PRId64 ": input quality: %s", m.utime, quality_summary(quality, reason).c_str());
            outbox_.push_back({std::move(bytes), std::move(ego_bytes), std::move(quality_bytes), quality,
                               frame.received_seconds, info.total_seconds});
            return;
        }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.last_error = "result: " + err;
    log("result of frame %" PRId64 " not published: %s", m.utime, err.c_str());
}
}  // namespace lidarflow::bridge
