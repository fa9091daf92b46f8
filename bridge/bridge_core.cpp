// SPDX-License-Identifier: MIT
#include "bridge_core.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdlib>
#include <cstring>
#include <random>

#include "bridge_frame.hpp"

namespace lidarflow::bridge {
namespace {

bool parse_int(const std::string &s, int64_t *out) {
    if (s.empty()) return false;
    char *end = nullptr;
    errno = 0;
    const long long v = std::strtoll(s.c_str(), &end, 10);
    if (errno != 0 || *end != '\0') return false;
    *out = v;
    return true;
}

bool parse_double(const std::string &s, double *out) {
    if (s.empty()) return false;
    char *end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (*end != '\0') return false;
    *out = v;
    return true;
}

// Sets one KEY=VALUE text option through the C ABI; returns "" or the reason it was refused.
// The key's type is asked first (the getters accept exactly the keys of their type), so the
// message is the setter's real one, e.g. the bounds of `threads`, not a type mismatch from
// trying the text as each type in turn.
std::string set_estimator_option(lf_options_t *options, const std::string &key, const std::string &value) {
    int64_t i = 0;
    double d = 0;
    const char *text = nullptr;
    int32_t st;
    if (lf_options_get_int(options, key.c_str(), &i) == LF_OK) {
        if (!parse_int(value, &i)) return "needs an integer";
        st = lf_options_set_int(options, key.c_str(), i);
    } else if (lf_options_get_float(options, key.c_str(), &d) == LF_OK) {
        if (!parse_double(value, &d)) return "needs a number";
        st = lf_options_set_float(options, key.c_str(), d);
    } else if (lf_options_get_string(options, key.c_str(), &text) == LF_OK) {
        st = lf_options_set_string(options, key.c_str(), value.c_str());
    } else {
        return lf_options_last_error(options);  // unknown key
    }
    return st == LF_OK ? std::string() : std::string(lf_options_last_error(options));
}

}  // namespace

double monotonic_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

Bridge::Bridge(const BridgeConfig &config, lcm_t *lcm)
    : config_(config), lcm_(lcm), pairing_(config.pair_buffer, config.lidar_buffer, config.lidar_tolerance_us) {}

std::unique_ptr<Bridge> Bridge::create(const BridgeConfig &config, lcm_t *lcm, std::string *error) {
    if (!lcm) {
        *error = "no LCM instance";
        return nullptr;
    }
    if (config.queue_capacity < 1 || config.lidar_buffer < 1 || config.lidar_wait_ms < 0 ||
        config.lidar_tolerance_us < 0 || config.step < 1 || config.step > 16 || config.shard_count < 1 ||
        config.shard_index < 0 || config.shard_index >= config.shard_count || config.pair_wait_ms < 0 ||
        config.pair_buffer < 1 || config.left_channel.empty() != config.right_channel.empty()) {
        *error = "queue capacity and LiDAR buffer must be >= 1, LiDAR wait and tolerance >= 0, step 1..16, "
                 "shard K/N with 0 <= K < N, pair wait >= 0 and buffer >= 1, left and right channel both or none";
        return nullptr;
    }
    if (config.shard_timeout_s > 0 && (config.shard_count < 2 || config.status_period_s <= 0)) {
        *error = "a shard timeout needs --shard K/N with N > 1 and a status period > 0 (the shards' heartbeats)";
        return nullptr;
    }
    if (config.have_lidar_to_camera) {
        const std::string why = check_lidar_to_camera(config.lidar_to_camera);
        if (!why.empty()) {
            *error = why;
            return nullptr;
        }
    }
    if (!config.shard_key.empty() && (config.shard_count < 2 || config.shard_key.size() < 16)) {
        *error = "a shard key needs --shard K/N with N > 1, and at least 16 bytes";
        return nullptr;
    }
    std::unique_ptr<Bridge> b(new Bridge(config, lcm));
    std::random_device random;
    while (b->instance_id_ == 0)
        b->instance_id_ = static_cast<int64_t>(static_cast<uint64_t>(random()) << 32 | static_cast<uint64_t>(random()));
    if (b->config_.shard_auth_channel.empty()) b->config_.shard_auth_channel = config.status_channel + "_MAC";
    if (lf_options_create(&b->options_) != LF_OK) {
        *error = std::string("estimator options: ") + lf_last_error(nullptr);
        return nullptr;
    }
    for (const auto &[key, value] : config.options) {
        const std::string why = set_estimator_option(b->options_, key, value);
        if (!why.empty()) {
            *error = "estimator option " + key + "=" + value + ": " + why;
            return nullptr;
        }
    }
    int64_t in_flight = 1;
    if (lf_options_get_int(b->options_, "frames_in_flight", &in_flight) == LF_OK && in_flight != 1) {
        // Each message is published as its frame's pair completes; late, out-of-step results
        // would carry the wrong frame's LiDAR flags.
        *error = "estimator option frames_in_flight=" + std::to_string(in_flight) +
                 ": the bridge computes one pair at a time (frames_in_flight must be 1)";
        return nullptr;
    }
    b->wake_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (b->wake_fd_ < 0) {
        *error = std::string("eventfd: ") + std::strerror(errno);
        return nullptr;
    }
    const std::pair<const std::string *, lcm_msg_handler_t> subs[] = {
        {&config.stereo_channel, &Bridge::on_stereo},
        {&config.lidar_channel, &Bridge::on_lidar},
        {&config.calibration_channel, &Bridge::on_calibration}};
    std::vector<std::pair<const std::string *, lcm_msg_handler_t>> channels(std::begin(subs), std::end(subs));
    if (!config.left_channel.empty()) {
        // A camera per channel replaces the stereo channel.
        channels.front() = {&config.left_channel, &Bridge::on_left};
        channels.push_back({&config.right_channel, &Bridge::on_right});
    }
    if (config.shard_count > 1 && config.status_period_s > 0 && config.shard_timeout_s != 0) {
        // The other shards' heartbeats, and the results, which settle their pairs.
        b->shard_timeout_ = config.shard_timeout_s < 0 ? 3 * config.status_period_s : config.shard_timeout_s;
        channels.push_back({&config.status_channel, &Bridge::on_status});
        channels.push_back({&config.flow_channel, &Bridge::on_flow});
        channels.push_back({&b->config_.shard_auth_channel, &Bridge::on_mac});  // MACs or receipts
    } else if (!config.shard_key.empty()) {
        channels.push_back({&b->config_.shard_auth_channel, &Bridge::on_mac});  // no watch: the others' tags to echo
    }
    if (!config.shard_key.empty()) b->echoes_.resize(static_cast<size_t>(config.shard_count));
    for (const auto &[channel, handler] : channels) {
        lcm_subscription_t *s = lcm_subscribe(lcm, channel->c_str(), handler, b.get());
        if (!s) {
            *error = "cannot subscribe to " + *channel;
            return nullptr;
        }
        b->subscriptions_.push_back(s);
    }
    {
        // Fail at start-up, not at the first frame, when the C ABI rejects the options or the
        // fixed camera. The library's one-time set-up (~0.1 s) is paid here too, rather than by
        // the receiving thread at the first calibration message, which held up the first frames;
        // after subscribing, so that what the publishers send meanwhile waits in LCM's buffers
        // instead of being missed (a calibration sent once, at a publisher's start).
        lf_calibration_t nominal;  // stands in for the camera that comes on the channel
        lf_calibration_init(&nominal);
        nominal.fx = nominal.fy = 700.0;
        nominal.cx = 600.0;
        nominal.cy = 180.0;
        nominal.baseline = 0.5;
        lf_estimator_t *probe = nullptr;
        if (lf_create(b->options_, config.fixed_calibration ? &config.calibration : &nominal, &probe) != LF_OK) {
            *error = std::string("estimator: ") + lf_last_error(nullptr);
            return nullptr;
        }
        lf_destroy(probe);
    }
    b->counters_.queue_capacity = config.queue_capacity;
    b->start_seconds_ = monotonic_seconds();
    // A shard that never sends a status is dead from shard_timeout_ after this one's start.
    if (b->shard_timeout_ > 0) {
        ShardWatch fresh;
        fresh.last_heartbeat = b->start_seconds_;
        b->shards_.assign(static_cast<size_t>(config.shard_count), fresh);
    }
    b->next_status_ = b->start_seconds_ + config.status_period_s;
    b->worker_ = std::thread(&Bridge::worker_loop, b.get());
    return b;
}

Bridge::~Bridge() {
    stop();
    for (lcm_subscription_t *s : subscriptions_) lcm_unsubscribe(lcm_, s);
    if (wake_fd_ >= 0) close(wake_fd_);
    lf_destroy(estimator_);
    lf_options_destroy(options_);
}

void Bridge::log(const char *format, ...) {
    va_list ap;
    va_start(ap, format);
    vlog(true, format, ap);
    va_end(ap);
}

void Bridge::log_each(const char *format, ...) {
    va_list ap;
    va_start(ap, format);
    vlog(false, format, ap);
    va_end(ap);
}

void Bridge::vlog(bool limited, const char *format, va_list ap) {
    if (!config_.log) return;
    char line[1024];
    std::vsnprintf(line, sizeof line, format, ap);
    if (!limited) {
        std::lock_guard<std::mutex> lock(log_mutex_);
        std::fprintf(config_.log, "lidarflow-lcm-bridge: %s\n", line);
        std::fflush(config_.log);
        return;
    }
    // Rate limit per kind of line (its format): a flood of bad messages must not become a flood
    // of lines. Up to kLogBurst lines per kLogWindowS seconds; the rest are counted, and the
    // count is told with the next line of that kind or at stop().
    std::lock_guard<std::mutex> lock(log_mutex_);
    LogLimit &l = log_limits_[format];
    const double now = monotonic_seconds();
    if (now - l.window_start >= kLogWindowS) {
        l.window_start = now;
        l.in_window = 0;
    }
    if (++l.in_window > kLogBurst) {
        ++l.suppressed;
        l.last = line;
        return;
    }
    if (l.suppressed)
        std::fprintf(config_.log, "lidarflow-lcm-bridge: %s (%" PRId64 " more like it not shown)\n", line, l.suppressed);
    else
        std::fprintf(config_.log, "lidarflow-lcm-bridge: %s\n", line);
    l.suppressed = 0;
    std::fflush(config_.log);
}

void Bridge::flush_log_limits() {
    if (!config_.log) return;
    std::lock_guard<std::mutex> lock(log_mutex_);
    for (auto &kv : log_limits_) {
        LogLimit &l = kv.second;
        if (!l.suppressed) continue;
        std::fprintf(config_.log, "lidarflow-lcm-bridge: %" PRId64 " more line(s) like this one not shown, the last: %s\n",
                     l.suppressed, l.last.c_str());
        l.suppressed = 0;
    }
    std::fflush(config_.log);
}

void Bridge::wake() {
    const uint64_t one = 1;
    // A full counter (never in practice) still leaves the fd readable, which is all we need.
    if (write(wake_fd_, &one, sizeof one) < 0 && errno != EAGAIN) log("eventfd write failed: %s", std::strerror(errno));
}

void Bridge::on_stereo(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    static_cast<Bridge *>(self)->handle_stereo(rbuf);
}
void Bridge::on_lidar(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    static_cast<Bridge *>(self)->handle_lidar(rbuf);
}
void Bridge::on_calibration(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    static_cast<Bridge *>(self)->handle_calibration(rbuf);
}


void Bridge::handle_stereo(const lcm_recv_buf_t *rbuf) {
    auto frame = std::make_unique<Frame>();
    // Per message by fingerprint: a channel may carry either type (and a driver may be swapped).
    const std::string err = message_fingerprint(rbuf->data, rbuf->data_size) == __bot_core_images_t_get_hash()
                                ? decode_bot_images(rbuf->data, rbuf->data_size, frame->stereo)
                                : decode_stereo(rbuf->data, rbuf->data_size, frame->stereo);
    frame->received_seconds = monotonic_seconds();
    frame->warm_up = warm_up_;
    std::lock_guard<std::mutex> lock(mutex_);
    ++(frame->warm_up ? counters_.warm_up_received : counters_.stereo_received);
    if (!err.empty()) {
        frame->count_in(counters_.dropped_malformed);
        counters_.last_error = "stereo: " + err;
        log("malformed message on %s (%u bytes), dropped: %s", config_.stereo_channel.c_str(), rbuf->data_size,
            err.c_str());
        return;
    }
    accept_locked(std::move(frame));
}

void Bridge::on_left(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    static_cast<Bridge *>(self)->handle_image(0, rbuf);
}
void Bridge::on_right(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    static_cast<Bridge *>(self)->handle_image(1, rbuf);
}

// One camera's image: paired with the other camera's image of equal utime, or left waiting.
void Bridge::handle_image(int side, const lcm_recv_buf_t *rbuf) {
    const char *channel = (side == 0 ? config_.left_channel : config_.right_channel).c_str();
    int64_t utime = 0;
    const std::string err = check_bot_image(rbuf->data, rbuf->data_size, &utime);
    const double now = monotonic_seconds();
    const auto *d = static_cast<const uint8_t *>(rbuf->data);
    std::unique_lock<std::mutex> lock(mutex_);
    if (!err.empty()) {
        ++counters_.stereo_received;
        ++counters_.dropped_malformed;
        counters_.last_error = "image: " + err;
        log("malformed message on %s (%u bytes), dropped: %s", channel, rbuf->data_size, err.c_str());
        return;
    }
    std::vector<uint8_t> other_bytes;
    std::vector<FramePairing::Unpaired> unpaired;
    const FramePairing::ImageOutcome outcome =
        pairing_.offer_image(side, utime, now, d, rbuf->data_size, &other_bytes, &unpaired);
    if (outcome == FramePairing::ImageOutcome::Twin) {
        // Two images of one camera at one time: the later one cannot be told apart, so it
        // has no partner of its own.
        ++counters_.stereo_received;
        ++counters_.dropped_unpaired;
        log("image %" PRId64 " on %s: a second one of that time, dropped as unpaired", utime, channel);
        return;
    }
    if (outcome == FramePairing::ImageOutcome::Waiting) {
        count_unpaired_locked(unpaired);
        return;
    }
    lock.unlock();
    auto frame = std::make_unique<Frame>();
    const std::string pair_err =
        side == 0 ? decode_bot_image_pair(d, rbuf->data_size, other_bytes.data(), other_bytes.size(), frame->stereo)
                  : decode_bot_image_pair(other_bytes.data(), other_bytes.size(), d, rbuf->data_size, frame->stereo);
    frame->received_seconds = now;
    lock.lock();
    ++counters_.stereo_received;
    if (!pair_err.empty()) {
        ++counters_.dropped_malformed;
        counters_.last_error = "stereo: " + pair_err;
        log("images %" PRId64 " on %s and %s do not make a stereo frame, dropped: %s", utime,
            config_.left_channel.c_str(), config_.right_channel.c_str(), pair_err.c_str());
        return;
    }
    accept_locked(std::move(frame));
}

// Called with mutex_ held: images that left the pairing without a partner, each counted as a
// stereo message received and dropped.
void Bridge::count_unpaired_locked(const std::vector<FramePairing::Unpaired> &unpaired) {
    for (const FramePairing::Unpaired &u : unpaired) {
        ++counters_.stereo_received;
        ++counters_.dropped_unpaired;
        log("image %" PRId64 " on %s has no partner on %s (%s): dropped as unpaired", u.utime,
            (u.side == 0 ? config_.left_channel : config_.right_channel).c_str(),
            (u.side == 0 ? config_.right_channel : config_.left_channel).c_str(), u.why);
    }
}

void Bridge::expire_unpaired() {
    const double deadline = monotonic_seconds() - config_.pair_wait_ms / 1000.0;
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<FramePairing::Unpaired> unpaired;
    pairing_.expire_images(deadline, &unpaired);
    count_unpaired_locked(unpaired);
}

// Called with mutex_ held for every decodable stereo frame: shard filter, calibration, order,
// then the latest-wins queue.
void Bridge::accept_locked(std::unique_ptr<Frame> frame) {
    const lidarflow_stereo_t &m = frame->stereo.msg();
    // A warm-up frame is counted nowhere (Frame::count_in), and the part's first frame checks
    // for transport gaps as if it came first.
    const bool warm_up = frame->warm_up;
    if (frame->stereo.has_frame_number() && !warm_up) count_transport_gap(m.frame_number);
    frame->index = frame->stereo.has_frame_number() ? m.frame_number : arrival_index_++;
    if (shard_timeout_ > 0 && !warm_up) note_pair_locked(frame->index, m.sequence, m.utime);
    if (config_.shard_count > 1) {
        // Pair (index - 1, index) belongs to shard index % N; a shard needs its t1 frames and
        // the frame before each as t0. Unsigned modulo: frame numbers may be negative.
        const auto n = static_cast<uint64_t>(config_.shard_count);
        const uint64_t r = static_cast<uint64_t>(frame->index) % n, k = static_cast<uint64_t>(config_.shard_index);
        if (r != k && (r + 1) % n != k) {
            frame->count_in(counters_.skipped_other_shard);
            return;
        }
        frame->t0_only = r != k;
    }
    if (config_.fixed_calibration) {
        frame->calibration = config_.calibration;
    } else {
        const FramePairing::CalibrationOutcome cal = pairing_.calibration_for(m.width, m.height, &frame->calibration);
        if (cal == FramePairing::CalibrationOutcome::None) {
            frame->count_in(counters_.dropped_no_calibration);
            if (!warned_no_calibration_)
                log("no calibration on %s yet (and no --calib): dropping stereo frames until one arrives",
                    config_.calibration_channel.c_str());
            warned_no_calibration_ = true;
            return;
        }
        if (cal == FramePairing::CalibrationOutcome::SizeMismatch) {
            frame->count_in(counters_.dropped_calibration_mismatch);
            log("stereo frame %" PRId64 " is %dx%d but the calibration is for %dx%d: dropped", m.utime, m.width,
                m.height, pairing_.calibration_width(), pairing_.calibration_height());
            return;
        }
    }
    if (have_last_ && m.sequence == last_sequence_ && m.utime <= last_utime_) {
        frame->count_in(counters_.dropped_out_of_order);
        log("stereo frame %" PRId64 " is not after the previous one (%" PRId64 "): dropped as out of order", m.utime,
            last_utime_);
        return;
    }
    have_last_ = true;
    last_sequence_ = m.sequence;
    last_utime_ = m.utime;
    if (static_cast<int>(queue_.size()) >= config_.queue_capacity) {
        queue_.front()->count_in(counters_.dropped_stale);  // the frame dropped, not this one
        queue_.pop_front();
    }
    queue_.push_back(std::move(frame));
    counters_.queue_depth = static_cast<int32_t>(queue_.size());
    counters_.max_queue_depth = std::max(counters_.max_queue_depth, counters_.queue_depth);
    cv_.notify_all();
}

// Called with mutex_ held, for every decodable stereo message. Only forward jumps count: UDP
// multicast on one network hardly reorders, and a smaller number is a publisher restart.
void Bridge::count_transport_gap(int64_t frame_number) {
    // Unsigned difference: the numbers are the publisher's and may sit anywhere in int64.
    const uint64_t step = static_cast<uint64_t>(frame_number) - static_cast<uint64_t>(last_frame_number_);
    if (have_frame_number_ && frame_number > last_frame_number_ && step > 1) {
        const auto lost = static_cast<int64_t>(step - 1);
        counters_.stereo_lost_in_transport += lost;
        log("%" PRId64 " stereo frame(s) lost in transport before frame number %" PRId64, lost, frame_number);
    }
    have_frame_number_ = true;
    last_frame_number_ = frame_number;
}

void Bridge::handle_lidar(const lcm_recv_buf_t *rbuf) {
    auto sweep = std::make_shared<LidarSweep>();
    const std::string err =
        message_fingerprint(rbuf->data, rbuf->data_size) == __bot_core_pointcloud_t_get_hash()
            ? decode_bot_pointcloud(rbuf->data, rbuf->data_size,
                                    config_.have_lidar_to_camera ? config_.lidar_to_camera : nullptr, *sweep)
            : decode_lidar(rbuf->data, rbuf->data_size, *sweep);
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.lidar_received;
    if (!err.empty()) {
        ++counters_.lidar_malformed;
        counters_.last_error = "lidar: " + err;
        log("malformed message on %s (%u bytes), ignored: %s", config_.lidar_channel.c_str(), rbuf->data_size,
            err.c_str());
        return;
    }
    counters_.lidar_buffered = static_cast<int32_t>(pairing_.add_lidar(std::move(sweep)));
    cv_.notify_all();
}

void Bridge::handle_calibration(const lcm_recv_buf_t *rbuf) {
    lf_calibration_t cal;
    int32_t w = 0, h = 0;
    std::string err = decode_calibration(rbuf->data, rbuf->data_size, &cal, &w, &h);
    if (err.empty()) {
        // The C ABI's ranges decide (finite values can still overflow fx * baseline): taking a
        // camera every push would then fail on would stall the stream until the next good one.
        // Default options, so that only the camera is judged here.
        lf_estimator_t *probe = nullptr;
        if (lf_create(nullptr, &cal, &probe) != LF_OK) err = lf_last_error(nullptr);
        lf_destroy(probe);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.calibration_received;
    if (!err.empty()) {
        ++counters_.calibration_malformed;
        counters_.last_error = "calibration: " + err;
        log("malformed message on %s (%u bytes), ignored: %s", config_.calibration_channel.c_str(),
            rbuf->data_size, err.c_str());
        return;
    }
    if (config_.fixed_calibration) return;  // --calib wins
    if (pairing_.set_calibration(cal, w, h))
        log("calibration: fx %.3f fy %.3f cx %.3f cy %.3f baseline %.5f m, images %dx%d%s", cal.fx, cal.fy, cal.cx,
            cal.cy, cal.baseline, w, h, w ? "" : " (any size)");
}

int Bridge::run_once(int timeout_ms) {
    if (stopped_) return 0;
    const double now = monotonic_seconds();
    int wait = std::max(timeout_ms, 0);
    if (config_.status_period_s > 0)
        wait = std::min(wait, std::max(0, static_cast<int>(1000.0 * (next_status_ - now)) + 1));
    pollfd fds[2] = {{lcm_get_fileno(lcm_), POLLIN, 0}, {wake_fd_, POLLIN, 0}};
    int ret = 0;
    if (poll(fds, 2, wait) > 0) {
        if (fds[1].revents & POLLIN) {
            uint64_t v;
            if (read(wake_fd_, &v, sizeof v) < 0 && errno != EAGAIN) log("eventfd read failed: %s", std::strerror(errno));
        }
        // Drain what is there (bounded, so results and status still go out under a flood).
        for (int n = 0; n < 256 && (fds[0].revents & POLLIN); ++n) {
            if (lcm_handle(lcm_) != 0) {
                ret = -1;
                break;
            }
            pollfd more = {lcm_get_fileno(lcm_), POLLIN, 0};
            if (poll(&more, 1, 0) <= 0) break;
        }
    }
    flush_outbox();
    if (!config_.left_channel.empty()) expire_unpaired();
    if (shard_timeout_ > 0) check_shards();
    if (config_.status_period_s > 0 && monotonic_seconds() >= next_status_) {
        publish_status();
        while (next_status_ <= monotonic_seconds()) next_status_ += config_.status_period_s;
    }
    return ret;
}

void Bridge::stop() {
    if (stopped_) return;
    stopped_ = true;
    if (!worker_.joinable()) return;  // create() failed before starting: nothing ran, nothing to report
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_worker_ = true;
    }
    cv_.notify_all();
    if (worker_.joinable()) worker_.join();
    {
        std::lock_guard<std::mutex> lock(mutex_);
        for (const std::unique_ptr<Frame> &f : queue_) f->count_in(counters_.dropped_shutdown);
        queue_.clear();
        std::vector<FramePairing::Unpaired> unpaired;
        pairing_.drop_all_images("the bridge stopped", &unpaired);
        count_unpaired_locked(unpaired);
        counters_.queue_depth = 0;
        counters_.busy = false;
    }
    flush_outbox();
    publish_status();
    flush_log_limits();
}

Counters Bridge::counters() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return counters_;
}

bool Bridge::idle() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.empty() && !counters_.busy && outbox_.empty();
}

}  // namespace lidarflow::bridge
