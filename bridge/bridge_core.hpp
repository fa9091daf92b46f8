// SPDX-License-Identifier: MIT
#pragma once
// The bridge between LCM and the lidarflow estimator, as a library so that tests drive it
// in-process (memq://) exactly as lidarflow-lcm-bridge does over the network.
//
// Threads. The thread that calls run_once() owns the lcm_t: it receives (LCM handlers run
// there) and publishes. Each stereo frame is queued for one worker thread that owns the
// estimator; the queue is a bounded latest-wins queue, so receiving never waits for the
// estimator: when it is full the oldest waiting frame is dropped ("stale"). The worker hands
// encoded results back through an outbox and wakes run_once() with an eventfd, so lcm_t is
// only ever used from one thread.
//
// Accounting. Every message on the stereo channel is counted once as received and ends as
// processed (given to the estimator) or dropped for one reason (Counters); in between it is
// queued or being worked on.
#include <lcm/lcm.h>

#include <condition_variable>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "frame_pairing.hpp"
#include "shard_auth.hpp"
#include "lidarflow/lidarflow.h"
#include "wire.hpp"

namespace lidarflow::bridge {

struct BridgeConfig {
    std::string stereo_channel = "LIDARFLOW_STEREO";
    // A camera per channel (bot_core.image_t each) instead of the stereo channel, when both are
    // set: images of equal utime are paired into a stereo frame. An image waits for its partner
    // up to pair_wait_ms after its arrival, and at most `pair_buffer` images wait per side (the
    // oldest goes first); an image that leaves without a partner is counted as a frame received
    // and dropped_unpaired.
    std::string left_channel, right_channel;
    int pair_wait_ms = 100;
    int pair_buffer = 8;
    std::string lidar_channel = "LIDARFLOW_LIDAR";
    std::string calibration_channel = "LIDARFLOW_CALIB";
    std::string flow_channel = "LIDARFLOW_FLOW";
    std::string status_channel = "LIDARFLOW_STATUS";
    // ego_motion_t of each result, published just before its scene_flow_t (no shard MAC: the
    // shards coordinate on the flow and status channels only).
    std::string ego_channel = "LIDARFLOW_EGO_MOTION";
    std::string quality_channel = "LIDARFLOW_QUALITY";
    // A fixed calibration (--calib); when set, calibration messages are counted but not used.
    bool fixed_calibration = false;
    lf_calibration_t calibration{};
    // LiDAR -> left rectified camera (row-major 4x4) for bot_core.pointcloud_t sweeps, which
    // carry points in the LiDAR frame and no transform (lidar_t carries its own).
    bool have_lidar_to_camera = false;
    double lidar_to_camera[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    int64_t lidar_tolerance_us = 20000;  // |t_lidar - t_stereo| for pairing
    int lidar_wait_ms = 30;              // how long a frame waits for a late LiDAR sweep
    int lidar_buffer = 8;                // LiDAR sweeps kept for pairing (oldest dropped)
    int queue_capacity = 1;              // frames waiting for the worker (latest wins)
    // --shard K/N: this process computes only the pairs whose t1 frame has index % N == K
    // (index: stereo_t.frame_number, or the arrival count for bot_core.images_t), and takes
    // the frame before as that pair's t0; other frames are counted as skipped_other_shard.
    int shard_index = 0, shard_count = 1;
    // --shard: a shard with no status on the status channel for this long is taken for dead
    // and its pairs counted as lost (see status_t.lcm); < 0: 3 status periods; 0: no watch.
    // Needs status_period_s > 0 (the shards' heartbeats).
    double shard_timeout_s = -1;
    // --shard-key: a key shared by the shards (raw bytes, >= 16). Each shard then follows every
    // status_t and scene_flow_t it publishes with a MAC message (shard_mac_message) on
    // shard_auth_channel, and its watch takes another shard's status only from a valid MAC that
    // echoes one of its own status tags of the last timeout (so a recording revives no one), and
    // a result as settling a pair only with a valid MAC from the shard that owns it; a valid MAC
    // acts alone, so messages without one never displace it. "" = no key: each result is
    // followed by a receipt naming the process (shard_receipt_message) instead, and the watch
    // tells processes apart by status_t.instance_id but trusts anyone on the bus who copies
    // them (see docs/LCM.md).
    std::string shard_key;
    std::string shard_auth_channel;  // "" = status_channel + "_MAC"
    FlowEncoding encoding = FlowEncoding::Int16;
    int step = 1;                        // flow subsampling
    double status_period_s = 1.0;        // <= 0: status only at shutdown
    // Estimator options "key" -> "value", applied in order with lf_options_set_int (if the value
    // is an integer), then lf_options_set_float (a number), then lf_options_set_string.
    std::vector<std::pair<std::string, std::string>> options;
    FILE *log = stderr;                  // one line per event worth telling; NULL = quiet
    bool verbose = false;                // also a line per published result
};

// Snapshot of the counters (status_t has the same meaning).
struct Counters {
    int64_t stereo_received = 0, stereo_processed = 0, results_published = 0, frames_with_lidar = 0;
    int64_t stereo_lost_in_transport = 0;  // gaps in stereo_t.frame_number
    int64_t dropped_stale = 0, dropped_out_of_order = 0, dropped_no_calibration = 0,
            dropped_calibration_mismatch = 0, dropped_malformed = 0, dropped_estimator_error = 0,
            dropped_shutdown = 0, dropped_unpaired = 0;
    int64_t skipped_other_shard = 0;       // --shard: frames only other shards need
    int32_t shards_dead = 0;               // --shard: other shards without a recent status
    int64_t pairs_lost_dead_shard = 0;     // their pairs without a result (this shard's share)
    // --shard watch (status_t has the same meaning): statuses and results of other shards
    // ignored for want of a valid MAC (with --shard-key: none within a second, a wrong one, or a
    // replayed status); statuses of a shard index from a process (instance) other than the one
    // holding it, or from one once heard doing so; results for another shard's pair without a
    // receipt from the process holding that shard within a second (without a key).
    int64_t shard_messages_refused = 0;
    int64_t shard_index_conflicts = 0;
    int64_t shard_results_ignored = 0;
    int64_t lidar_received = 0, lidar_malformed = 0, lidar_rejected = 0;
    // LiDAR-frame sweeps whose transform the estimator did not carry (it changed within a
    // pair): moved by the bridge, one float cast (wire.hpp, LidarSweep). Not in status_t.
    int64_t lidar_moved_by_bridge = 0;
    // Frame pairs not computed because the calibration changed between their two frames (the
    // estimator starts over with the new camera). Pairs, not stereo messages: not part of the
    // accounting identity.
    int64_t pairs_lost_calibration_change = 0;
    int64_t calibration_received = 0, calibration_malformed = 0;
    int32_t queue_depth = 0, queue_capacity = 0, max_queue_depth = 0;
    int32_t lidar_buffered = 0;
    bool busy = false;
    double latency_last_ms = 0, latency_mean_ms = 0, latency_max_ms = 0;
    double compute_last_ms = 0, compute_mean_ms = 0;
    int64_t status_published = 0;
    std::string last_error;
    // Published results by input quality (lf_get_quality): ok, and per flag bit (a result with
    // several flags counts under each). Not in status_t.
    int64_t quality_ok = 0;
    int64_t quality_flagged[5] = {};
    // set_warm_up(): stereo messages taken while it was on, those the estimator took, and the
    // pairs computed from them (t0 a warm-up frame) and not published. Kept out of every count
    // above (and of status_t): they are not the stream's part being replayed.
    int64_t warm_up_received = 0, warm_up_fed = 0, warm_up_pairs = 0;

    // "12 ok, 1 blank_frame" (flags never seen left out).
    std::string quality_text() const;

    int64_t dropped() const {
        return dropped_stale + dropped_out_of_order + dropped_no_calibration + dropped_calibration_mismatch +
               dropped_malformed + dropped_estimator_error + dropped_shutdown + dropped_unpaired;
    }
};

class Bridge {
public:
    // Subscribes to the input channels of `lcm` (borrowed; must outlive the bridge) and starts
    // the worker. Returns nullptr and sets *error when the estimator options are invalid, the
    // fixed calibration is rejected by the C ABI, or a subscription or the eventfd fails.
    static std::unique_ptr<Bridge> create(const BridgeConfig &config, lcm_t *lcm, std::string *error);
    ~Bridge();  // stop(), then unsubscribes
    Bridge(const Bridge &) = delete;
    Bridge &operator=(const Bridge &) = delete;

    // Waits up to timeout_ms for LCM input or worker results, handles what arrived, publishes
    // finished results and, when due, the status. Returns -1 when lcm_handle failed, else 0.
    // Call from one thread only (the one that owns the lcm_t).
    int run_once(int timeout_ms);

    // Stops the worker (it finishes the frame in progress), counts still-queued frames as
    // dropped_shutdown, publishes the remaining results and a final status. Idempotent; the
    // run_once() thread only.
    void stop();

    // Publishes a status now, besides the periodic ones (offline replay keeps its own clock).
    void publish_status_now() { publish_status(); }

    // Offline replay's warm-up: while on, messages on the stereo channel only feed the
    // estimator's stream (the priors a pair takes from the pairs before it): counted in
    // Counters::warm_up_*, never as received, processed or dropped, and the result of a pair
    // whose t0 is such a frame is computed but not published. The run_once() thread only.
    void set_warm_up(bool on) { warm_up_ = on; }

    Counters counters() const;
    // This process's status_t.instance_id: random, drawn at create(), never 0. Any thread.
    int64_t instance_id() const { return instance_id_; }
    // True when no frame is queued or being worked on and no result awaits publication.
    bool idle() const;

private:
    struct Frame;
    Bridge(const BridgeConfig &config, lcm_t *lcm);
    static void on_stereo(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    static void on_lidar(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    static void on_calibration(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    static void on_status(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    static void on_flow(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    void note_pair_locked(int64_t index, int32_t sequence, int64_t utime);
    bool counts_for_locked(int shard) const;
    void check_shards();
    void handle_stereo(const lcm_recv_buf_t *rbuf);
    static void on_left(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    static void on_right(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    void handle_image(int side, const lcm_recv_buf_t *rbuf);
    void count_unpaired_locked(const std::vector<FramePairing::Unpaired> &unpaired);
    void expire_unpaired();
    void accept_locked(std::unique_ptr<Frame> frame);
    void count_transport_gap(int64_t frame_number);
    void handle_lidar(const lcm_recv_buf_t *rbuf);
    void handle_calibration(const lcm_recv_buf_t *rbuf);
    void worker_loop();
    void process(Frame &frame, std::shared_ptr<const LidarSweep> sweep);
    void flush_outbox();
    void publish_status();
    void log(const char *format, ...) __attribute__((format(printf, 2, 3)));       // rate-limited
    void log_each(const char *format, ...) __attribute__((format(printf, 2, 3)));  // not limited
    void vlog(bool limited, const char *format, va_list ap);
    void flush_log_limits();  // tells the lines the rate limit held back
    void wake();

    BridgeConfig config_;
    lcm_t *lcm_;
    int64_t instance_id_ = 0;
    // log(): per format, lines in the current window and those not shown.
    static constexpr int kLogBurst = 10;
    static constexpr double kLogWindowS = 10.0;
    struct LogLimit {
        double window_start = -1e300;
        int in_window = 0;
        int64_t suppressed = 0;
        std::string last;
    };
    std::mutex log_mutex_;
    std::map<const char *, LogLimit> log_limits_;
    lf_options_t *options_ = nullptr;
    std::vector<lcm_subscription_t *> subscriptions_;
    int wake_fd_ = -1;
    double start_seconds_ = 0, next_status_ = 0;
    bool stopped_ = false;
    bool warm_up_ = false;            // set_warm_up(); the run_once() thread's

    mutable std::mutex mutex_;        // everything below
    std::condition_variable cv_;      // queue, LiDAR arrivals, stop
    std::deque<std::unique_ptr<Frame>> queue_;
    FramePairing pairing_;            // camera images, LiDAR sweeps and the channel's calibration
    bool warned_no_calibration_ = false;
    bool have_last_ = false;          // the last accepted frame, for the order check
    bool have_frame_number_ = false;  // the last decodable stereo message, for transport gaps
    int64_t last_frame_number_ = 0;
    int64_t arrival_index_ = 0;       // decodable frames without a frame_number, for --shard
    int32_t last_sequence_ = 0;
    int64_t last_utime_ = 0;
    bool stop_worker_ = false;
    // --shard watch (shard_timeout_ > 0): every other shard's last heartbeat and the t1 times of
    // its pairs for which no result was seen yet (bounded; the newest kept).
    struct ShardWatch {
        double last_heartbeat = 0;
        bool dead = false;
        std::deque<int64_t> pending;
        int64_t holder = 0;             // instance_id of the process holding the index; 0: none yet
        std::deque<int64_t> rejected;   // instances heard claiming it while another held it
        bool have_status_utime = false;  // --shard-key: the latest authenticated status's utime
        int64_t status_utime = 0;
    };
    // Messages waiting for their receipt (results without a key), and receipts waiting for their
    // message. With --shard-key a valid MAC acts alone (it carries what the watch needs), so
    // these lists only count what no MAC vouched for: messages without one yet (digest), and the
    // digests valid MACs vouched for; unauthenticated traffic can fill them, never displace a MAC.
    struct AwaitingMac {
        bool status;                  // else a result
        int32_t shard;
        int64_t utime;                // status_t.utime, or the result's t1 utime
        int64_t instance;             // status_t.instance_id
        std::vector<uint8_t> mac;     // the expected receipt with instance 0; keyed: the digest
        double arrival;
    };
    std::deque<AwaitingMac> awaiting_mac_;
    struct ReceivedMac {
        std::vector<uint8_t> mac;     // a receipt's with its instance set to 0; keyed: the digest
        int64_t instance;             // a receipt's sender; keyed: the MAC's shard
        bool status;                  // keyed: a status's MAC, else a result's
        double arrival;
    };
    std::deque<ReceivedMac> received_macs_;
    // --shard-key: per shard, the tag of the newest status MAC heard from it (echoed in this
    // one's MACs), and this one's own status tags of the last shard timeout with their time.
    struct Echo {
        bool have = false;
        int64_t utime = 0;
        uint64_t tag = 0;
    };
    std::vector<Echo> echoes_;
    std::deque<std::pair<uint64_t, double>> own_tags_;
    bool warned_old_mac_ = false;
    static void on_mac(const lcm_recv_buf_t *rbuf, const char *channel, void *self);
    void on_keyed_mac_locked(const ShardMac &m, double now);
    bool vouched_locked(const std::vector<uint8_t> &digest, int32_t shard, bool status);
    // heard_at: when the status proves its shard alive (keyed: when this one published the status
    // it answers; else its arrival).
    void apply_status_locked(int32_t shard, int64_t utime, int64_t instance, double heard_at);
    void apply_flow_locked(int32_t shard, int64_t utime);
    void apply_receipt_locked(int32_t shard, int64_t utime, int64_t instance);
    void expire_macs_locked(double now);
    void publish_mac(const std::string &channel, const void *payload, size_t size, ShardMacKind kind, int64_t utime);
    double shard_timeout_ = 0;
    std::vector<ShardWatch> shards_;
    bool watch_have_prev_ = false;    // the previous decodable frame, to know which pairs exist
    int64_t watch_prev_index_ = 0;
    int32_t watch_prev_sequence_ = 0;
    bool warned_foreign_split_ = false;
    struct Outgoing {
        std::vector<uint8_t> bytes;
        std::vector<uint8_t> ego_bytes;  // the result's ego_motion_t
        std::vector<uint8_t> quality_bytes;  // the result's quality_t
        uint32_t quality_flags;
        double received_seconds;
        double compute_seconds;
    };
    std::vector<Outgoing> outbox_;
    Counters counters_;
    double latency_sum_ms_ = 0, compute_sum_ms_ = 0;
    std::thread worker_;

    // Worker-only state.
    lf_estimator_t *estimator_ = nullptr;
    lf_calibration_t estimator_calibration_{};
    bool estimator_has_frame_ = false;
    int32_t prev_sequence_ = 0;
    int64_t prev_utime_ = 0, prev_lidar_utime_ = 0;
    uint32_t prev_width_ = 0, prev_height_ = 0;
    int32_t prev_format_ = 0;
    bool prev_had_lidar_ = false;
    bool prev_warm_up_ = false;       // the frame the estimator holds was a warm-up frame
    int64_t prev_index_ = 0;          // --shard: index of the frame the estimator holds
};

// Monotonic clock [s].
double monotonic_seconds();

}  // namespace lidarflow::bridge
