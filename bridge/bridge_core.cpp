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

#include <openssl/evp.h>
#include <openssl/hmac.h>

#include "lidarflow_status_t.h"

namespace lidarflow::bridge {
namespace {

bool same_calibration(const lf_calibration_t &a, const lf_calibration_t &b) {
    return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.baseline == b.baseline;
}

bool carries_transform(const lf_calibration_t &cal, const double *T) {
    return cal.has_lidar_to_camera == 1 && std::equal(T, T + 16, cal.lidar_to_camera);
}

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

int64_t wall_utime() {
    return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

}  // namespace

double monotonic_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Bridge::Frame {
    StereoMessage stereo;
    // --shard: the frame's index in the stream, and whether it only serves as the t0 of this
    // shard's next pair (its own pair, with the frame before, belongs to another shard).
    int64_t index = 0;
    bool t0_only = false;
    lf_calibration_t calibration{};
    double received_seconds = 0;
};

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
    if (config.fixed_calibration) {
        // Fail at start-up, not at the first frame, when the C ABI rejects the options or camera.
        lf_estimator_t *probe = nullptr;
        if (lf_create(b->options_, &config.calibration, &probe) != LF_OK) {
            *error = std::string("estimator: ") + lf_last_error(nullptr);
            return nullptr;
        }
        lf_destroy(probe);
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
    }
    for (const auto &[channel, handler] : channels) {
        lcm_subscription_t *s = lcm_subscribe(lcm, channel->c_str(), handler, b.get());
        if (!s) {
            *error = "cannot subscribe to " + *channel;
            return nullptr;
        }
        b->subscriptions_.push_back(s);
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

void Bridge::on_status(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    auto *b = static_cast<Bridge *>(self);
    StatusMessage status;
    if (!decode_status(rbuf->data, rbuf->data_size, status).empty()) return;  // not ours to judge
    const lidarflow_status_t &f = status.fields;
    // Computed before the lock: a MAC costs a pass over the message.
    const bool ours = f.shard_count == b->config_.shard_count && f.shard_index >= 0 && f.shard_index < f.shard_count &&
                      f.shard_index != b->config_.shard_index;
    std::vector<uint8_t> mac;
    if (ours && !b->config_.shard_key.empty())
        mac = shard_mac_message(b->config_.shard_key, f.shard_index, f.shard_count, b->config_.status_channel,
                                rbuf->data, rbuf->data_size);
    std::lock_guard<std::mutex> lock(b->mutex_);
    if (f.shard_count != b->config_.shard_count || f.shard_index < 0 || f.shard_index >= f.shard_count) {
        if (!b->warned_foreign_split_)
            b->log("a status from shard %d/%d on %s is not of this split (N = %d): ignored", f.shard_index,
                   f.shard_count, b->config_.status_channel.c_str(), b->config_.shard_count);
        b->warned_foreign_split_ = true;
        return;
    }
    if (f.shard_index == b->config_.shard_index && f.instance_id == b->instance_id_) return;  // our own, looped back
    if (f.shard_index == b->config_.shard_index) {
        // Another process claims this one's index: only the others can tell which is genuine
        // (with a key, a status without a MAC is no claim).
        if (!b->config_.shard_key.empty()) return;
        ++b->counters_.shard_index_conflicts;
        b->log("a status of shard %d/%d from another process (instance %016" PRIx64 "): is this index claimed twice?",
               f.shard_index, f.shard_count, static_cast<uint64_t>(f.instance_id));
        return;
    }
    if (b->config_.shard_key.empty()) {
        b->apply_status_locked(f.shard_index, f.utime, f.instance_id);
        return;
    }
    const double now = monotonic_seconds();
    for (auto it = b->received_macs_.begin(); it != b->received_macs_.end(); ++it)
        if (it->mac == mac) {
            b->received_macs_.erase(it);
            b->apply_status_locked(f.shard_index, f.utime, f.instance_id);
            return;
        }
    b->awaiting_mac_.push_back({true, f.shard_index, f.utime, f.instance_id, std::move(mac), now});
    b->expire_macs_locked(now);
}

// A status that counts (authenticated with --shard-key): the shard is alive, if it comes from
// the process holding the index. The first process heard holds it; another one takes it over
// only once the holder is silent for the timeout (a restart), and never one heard claiming the
// index while the holder lived (a second process or a forger: it must not keep the index alive).
void Bridge::apply_status_locked(int32_t shard, int64_t utime, int64_t instance) {
    ShardWatch &w = shards_[static_cast<size_t>(shard)];
    const double now = monotonic_seconds();
    if (instance != w.holder) {
        const bool holder_alive = w.holder != 0 && !w.dead && now - w.last_heartbeat <= shard_timeout_;
        const bool rejected = std::find(w.rejected.begin(), w.rejected.end(), instance) != w.rejected.end();
        if (holder_alive || rejected) {
            ++counters_.shard_index_conflicts;
            if (!rejected) {
                w.rejected.push_back(instance);
                if (w.rejected.size() > 16) w.rejected.pop_front();
            }
            log("shard %d/%d: a status of instance %016" PRIx64 " while %016" PRIx64
                " holds the index: a second process or a forger, ignored from now on",
                shard, config_.shard_count, static_cast<uint64_t>(instance), static_cast<uint64_t>(w.holder));
            return;
        }
        if (w.holder != 0)
            log("shard %d/%d: now held by a new process (instance %016" PRIx64 ", was %016" PRIx64 ")", shard,
                config_.shard_count, static_cast<uint64_t>(instance), static_cast<uint64_t>(w.holder));
        w.holder = instance;
    }
    if (!config_.shard_key.empty()) {
        // A genuine status recorded and sent again must not keep a dead shard alive.
        if (w.have_status_utime && utime <= w.status_utime) {
            ++counters_.shard_messages_refused;
            log("a status of shard %d/%d with a MAC but not newer than its last (utime %" PRId64 " <= %" PRId64
                "): a replay, ignored", shard, config_.shard_count, utime, w.status_utime);
            return;
        }
        w.have_status_utime = true;
        w.status_utime = utime;
    }
    w.last_heartbeat = now;
    if (w.dead) {
        // A restarted shard starts from nothing: what it had is already counted.
        w.dead = false;
        w.pending.clear();
        --counters_.shards_dead;
        log("shard %d/%d is back (status received)", shard, config_.shard_count);
    }
}

void Bridge::on_flow(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    auto *b = static_cast<Bridge *>(self);
    int64_t utime = 0;
    if (!scene_flow_utime(rbuf->data, rbuf->data_size, &utime)) return;
    std::unique_lock<std::mutex> lock(b->mutex_);
    // Only the shard that owns the pair settles it: the MAC (with a key), or else the receipt
    // of the process holding that shard, must follow the result.
    int32_t owner = -1;
    for (size_t k = 0; k < b->shards_.size() && owner < 0; ++k) {
        const std::deque<int64_t> &p = b->shards_[k].pending;
        if (std::find(p.begin(), p.end(), utime) != p.end()) owner = static_cast<int32_t>(k);
    }
    if (owner < 0) return;  // settles nothing
    lock.unlock();
    const bool keyed = !b->config_.shard_key.empty();
    std::vector<uint8_t> mac =
        keyed ? shard_mac_message(b->config_.shard_key, owner, b->config_.shard_count, b->config_.flow_channel,
                                  rbuf->data, rbuf->data_size)
              : shard_receipt_message(owner, b->config_.shard_count, 0, b->config_.flow_channel, rbuf->data,
                                      rbuf->data_size);
    lock.lock();
    const double now = monotonic_seconds();
    for (auto it = b->received_macs_.begin(); it != b->received_macs_.end(); ++it)
        if (it->mac == mac) {
            const int64_t instance = it->instance;
            b->received_macs_.erase(it);
            if (keyed) b->apply_flow_locked(owner, utime);
            else b->apply_receipt_locked(owner, utime, instance);
            return;
        }
    b->awaiting_mac_.push_back({false, owner, utime, 0, std::move(mac), now});
    b->expire_macs_locked(now);
}

// A result with its receipt (no key): it settles the pair only when the process that sent it
// holds the owner's index (or no status of the owner was heard yet).
void Bridge::apply_receipt_locked(int32_t shard, int64_t utime, int64_t instance) {
    const ShardWatch &w = shards_[static_cast<size_t>(shard)];
    if (w.holder != 0 && instance != w.holder) {
        ++counters_.shard_results_ignored;
        log("a result for shard %d/%d's pair ending at %" PRId64 " from instance %016" PRIx64 ", not its holder %016" PRIx64
            ": ignored",
            shard, config_.shard_count, utime, static_cast<uint64_t>(instance), static_cast<uint64_t>(w.holder));
        return;
    }
    apply_flow_locked(shard, utime);
}

void Bridge::apply_flow_locked(int32_t shard, int64_t utime) {
    std::deque<int64_t> &p = shards_[static_cast<size_t>(shard)].pending;
    const auto it = std::find(p.begin(), p.end(), utime);
    if (it != p.end()) p.erase(it);
}

void Bridge::on_mac(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    auto *b = static_cast<Bridge *>(self);
    const auto *d = static_cast<const uint8_t *>(rbuf->data);
    // A MAC with a key, a receipt without: the other kind is no proof here.
    const bool keyed = !b->config_.shard_key.empty();
    if (rbuf->data_size != 48 || std::memcmp(d, keyed ? "LFMAC\x01\0\0" : "LFRCP\x01\0\0", 8) != 0) return;
    std::vector<uint8_t> mac(d, d + rbuf->data_size);
    int64_t instance = 0;
    if (!keyed) {
        uint64_t u = 0;
        for (int i = 0; i < 8; ++i) u = u << 8 | mac[16 + i];
        instance = static_cast<int64_t>(u);
        std::fill(mac.begin() + 16, mac.begin() + 24, 0);  // matched without it, then checked
    }
    std::lock_guard<std::mutex> lock(b->mutex_);
    const double now = monotonic_seconds();
    for (auto it = b->awaiting_mac_.begin(); it != b->awaiting_mac_.end(); ++it)
        if (it->mac == mac) {
            const AwaitingMac m = std::move(*it);
            b->awaiting_mac_.erase(it);
            if (m.status) b->apply_status_locked(m.shard, m.utime, m.instance);
            else if (keyed) b->apply_flow_locked(m.shard, m.utime);
            else b->apply_receipt_locked(m.shard, m.utime, instance);
            return;
        }
    b->received_macs_.push_back({std::move(mac), instance, now});
    b->expire_macs_locked(now);
}

// Messages whose MAC did not come within a second (or a wrong one did) are refused; MACs
// without their message are forgotten. Both lists are bounded.
void Bridge::expire_macs_locked(double now) {
    constexpr double kMacWaitS = 1.0;
    constexpr size_t kMaxWaiting = 1024;
    while (!awaiting_mac_.empty() &&
           (now - awaiting_mac_.front().arrival > kMacWaitS || awaiting_mac_.size() > kMaxWaiting)) {
        const AwaitingMac &m = awaiting_mac_.front();
        if (config_.shard_key.empty()) {
            ++counters_.shard_results_ignored;
            log("a result for shard %d/%d's pair ending at %" PRId64 " came without a receipt from that shard: ignored",
                m.shard, config_.shard_count, m.utime);
        } else {
            ++counters_.shard_messages_refused;
            log("a %s claiming shard %d/%d (utime %" PRId64 ") has no valid MAC (--shard-key): ignored",
                m.status ? "status" : "result", m.shard, config_.shard_count, m.utime);
        }
        awaiting_mac_.pop_front();
    }
    while (!received_macs_.empty() &&
           (now - received_macs_.front().arrival > kMacWaitS || received_macs_.size() > kMaxWaiting))
        received_macs_.pop_front();
}

void Bridge::publish_mac(const std::string &channel, const void *payload, size_t size) {
    if (config_.shard_count < 2) return;
    // Without a key only results get a receipt: a status names its process itself.
    if (config_.shard_key.empty() && channel != config_.flow_channel) return;
    const std::vector<uint8_t> m =
        config_.shard_key.empty()
            ? shard_receipt_message(config_.shard_index, config_.shard_count, instance_id_, channel, payload, size)
            : shard_mac_message(config_.shard_key, config_.shard_index, config_.shard_count, channel, payload, size);
    if (m.empty() || lcm_publish(lcm_, config_.shard_auth_channel.c_str(), m.data(), static_cast<unsigned>(m.size())) != 0)
        log("publishing the MAC of a message on %s failed", channel.c_str());
}

std::vector<uint8_t> shard_mac_message(const std::string &key, int32_t index, int32_t count, const std::string &channel,
                                       const void *payload, size_t size) {
    static const char kDomain[] = "lidarflow shard mac v1";  // with its NUL
    std::vector<uint8_t> in;
    in.reserve(sizeof kDomain + 8 + channel.size() + 1 + size);
    in.insert(in.end(), kDomain, kDomain + sizeof kDomain);
    uint8_t head[8];
    for (int i = 0; i < 4; ++i) {
        head[i] = static_cast<uint8_t>(static_cast<uint32_t>(index) >> (24 - 8 * i));
        head[4 + i] = static_cast<uint8_t>(static_cast<uint32_t>(count) >> (24 - 8 * i));
    }
    in.insert(in.end(), head, head + 8);
    in.insert(in.end(), channel.begin(), channel.end());
    in.push_back(0);
    const auto *p = static_cast<const uint8_t *>(payload);
    in.insert(in.end(), p, p + size);
    std::vector<uint8_t> out(48);
    std::memcpy(out.data(), "LFMAC\x01\0\0", 8);
    std::memcpy(out.data() + 8, head, 8);
    unsigned int len = 0;
    if (!HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), in.data(), in.size(), out.data() + 16, &len) ||
        len != 32)
        return {};
    return out;
}

std::vector<uint8_t> shard_receipt_message(int32_t index, int32_t count, int64_t instance, const std::string &channel,
                                           const void *payload, size_t size) {
    std::vector<uint8_t> out(48);
    std::memcpy(out.data(), "LFRCP\x01\0\0", 8);
    for (int i = 0; i < 4; ++i) {
        out[8 + i] = static_cast<uint8_t>(static_cast<uint32_t>(index) >> (24 - 8 * i));
        out[12 + i] = static_cast<uint8_t>(static_cast<uint32_t>(count) >> (24 - 8 * i));
    }
    for (int i = 0; i < 8; ++i) out[16 + i] = static_cast<uint8_t>(static_cast<uint64_t>(instance) >> (56 - 8 * i));
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    const bool ok = ctx && EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) == 1 &&
                    EVP_DigestUpdate(ctx, channel.c_str(), channel.size() + 1) == 1 &&
                    EVP_DigestUpdate(ctx, payload, size) == 1 && EVP_DigestFinal_ex(ctx, digest, &len) == 1 && len == 32;
    EVP_MD_CTX_free(ctx);
    if (!ok) return {};
    std::memcpy(out.data() + 24, digest, 24);
    return out;
}

std::string read_shard_key(const std::string &path, std::string *key) {
    std::FILE *f = std::fopen(path.c_str(), "rb");
    if (!f) return path + ": " + std::strerror(errno);
    std::string k;
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0 && k.size() < (1u << 20)) k.append(buf, n);
    const bool bad = std::ferror(f);
    std::fclose(f);
    if (bad) return path + ": read error";
    while (!k.empty() && (k.back() == '\n' || k.back() == '\r')) k.pop_back();  // `openssl rand -hex 32 >FILE`
    if (k.size() < 16) return path + ": a shard key needs at least 16 bytes";
    *key = std::move(k);
    return "";
}

// Whether this shard counts the pairs of dead shard `shard`: it is the first live one after it.
bool Bridge::counts_for_locked(int shard) const {
    const int n = config_.shard_count;
    for (int k = (shard + 1) % n; k != shard; k = (k + 1) % n) {
        if (k == config_.shard_index) return true;
        if (!shards_[static_cast<size_t>(k)].dead) return false;
    }
    return false;
}

// Called with mutex_ held for every decodable stereo frame while watching: the pair ending at
// it, if there is one (consecutive index, same sequence), belongs to shard index % N.
void Bridge::note_pair_locked(int64_t index, int32_t sequence, int64_t utime) {
    const bool pair = watch_have_prev_ && static_cast<uint64_t>(index) - 1 == static_cast<uint64_t>(watch_prev_index_) &&
                      sequence == watch_prev_sequence_;
    watch_have_prev_ = true;
    watch_prev_index_ = index;
    watch_prev_sequence_ = sequence;
    const auto owner = static_cast<int>(static_cast<uint64_t>(index) % static_cast<uint64_t>(config_.shard_count));
    if (!pair || owner == config_.shard_index) return;
    ShardWatch &w = shards_[static_cast<size_t>(owner)];
    if (w.dead) {
        if (counts_for_locked(owner)) {
            ++counters_.pairs_lost_dead_shard;
            if (config_.verbose) log("pair ending at %" PRId64 " lost: its shard %d is dead", utime, owner);
        }
        return;
    }
    w.pending.push_back(utime);
    if (w.pending.size() > 4096) w.pending.pop_front();
}

void Bridge::check_shards() {
    const double now = monotonic_seconds();
    std::lock_guard<std::mutex> lock(mutex_);
    expire_macs_locked(now);
    for (size_t k = 0; k < shards_.size(); ++k) {
        ShardWatch &w = shards_[k];
        if (static_cast<int>(k) == config_.shard_index || w.dead || now - w.last_heartbeat <= shard_timeout_) continue;
        w.dead = true;
        ++counters_.shards_dead;
        const bool mine = counts_for_locked(static_cast<int>(k));
        if (mine) counters_.pairs_lost_dead_shard += static_cast<int64_t>(w.pending.size());
        if (mine)
            log("shard %zu/%d: no status for %.1f s, taken for dead; counted here as lost: %zu pair(s) without a "
                "result so far, and its further ones",
                k, config_.shard_count, now - w.last_heartbeat, w.pending.size());
        else
            log("shard %zu/%d: no status for %.1f s, taken for dead; %zu pair(s) without a result so far, counted by "
                "another shard",
                k, config_.shard_count, now - w.last_heartbeat, w.pending.size());
        w.pending.clear();
    }
}

void Bridge::handle_stereo(const lcm_recv_buf_t *rbuf) {
    auto frame = std::make_unique<Frame>();
    // Per message by fingerprint: a channel may carry either type (and a driver may be swapped).
    const std::string err = message_fingerprint(rbuf->data, rbuf->data_size) == __bot_core_images_t_get_hash()
                                ? decode_bot_images(rbuf->data, rbuf->data_size, frame->stereo)
                                : decode_stereo(rbuf->data, rbuf->data_size, frame->stereo);
    frame->received_seconds = monotonic_seconds();
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.stereo_received;
    if (!err.empty()) {
        ++counters_.dropped_malformed;
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
    if (frame->stereo.has_frame_number()) count_transport_gap(m.frame_number);
    frame->index = frame->stereo.has_frame_number() ? m.frame_number : arrival_index_++;
    if (shard_timeout_ > 0) note_pair_locked(frame->index, m.sequence, m.utime);
    if (config_.shard_count > 1) {
        // Pair (index - 1, index) belongs to shard index % N; a shard needs its t1 frames and
        // the frame before each as t0. Unsigned modulo: frame numbers may be negative.
        const auto n = static_cast<uint64_t>(config_.shard_count);
        const uint64_t r = static_cast<uint64_t>(frame->index) % n, k = static_cast<uint64_t>(config_.shard_index);
        if (r != k && (r + 1) % n != k) {
            ++counters_.skipped_other_shard;
            return;
        }
        frame->t0_only = r != k;
    }
    if (config_.fixed_calibration) {
        frame->calibration = config_.calibration;
    } else {
        const FramePairing::CalibrationOutcome cal = pairing_.calibration_for(m.width, m.height, &frame->calibration);
        if (cal == FramePairing::CalibrationOutcome::None) {
            ++counters_.dropped_no_calibration;
            if (!warned_no_calibration_)
                log("no calibration on %s yet (and no --calib): dropping stereo frames until one arrives",
                    config_.calibration_channel.c_str());
            warned_no_calibration_ = true;
            return;
        }
        if (cal == FramePairing::CalibrationOutcome::SizeMismatch) {
            ++counters_.dropped_calibration_mismatch;
            log("stereo frame %" PRId64 " is %dx%d but the calibration is for %dx%d: dropped", m.utime, m.width,
                m.height, pairing_.calibration_width(), pairing_.calibration_height());
            return;
        }
    }
    if (have_last_ && m.sequence == last_sequence_ && m.utime <= last_utime_) {
        ++counters_.dropped_out_of_order;
        log("stereo frame %" PRId64 " is not after the previous one (%" PRId64 "): dropped as out of order", m.utime,
            last_utime_);
        return;
    }
    have_last_ = true;
    last_sequence_ = m.sequence;
    last_utime_ = m.utime;
    if (static_cast<int>(queue_.size()) >= config_.queue_capacity) {
        queue_.pop_front();
        ++counters_.dropped_stale;
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
            ++counters_.dropped_shutdown;
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
        ++counters_.dropped_estimator_error;
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
        ++counters_.pairs_lost_calibration_change;
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
            ++counters_.lidar_rejected;
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
    const bool previous_lidar = prev_had_lidar_;
    const int64_t previous_lidar_utime = prev_lidar_utime_;
    estimator_has_frame_ = true;
    prev_sequence_ = m.sequence;
    prev_index_ = frame.index;
    prev_utime_ = m.utime;
    prev_width_ = left.width;
    prev_height_ = left.height;
    prev_format_ = left.format;
    prev_had_lidar_ = with_lidar;
    prev_lidar_utime_ = with_lidar ? sweep->utime : 0;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        ++counters_.stereo_processed;
        counters_.frames_with_lidar += with_lidar ? 1 : 0;
    }
    if (!had_previous || !lf_has_result(estimator_)) return;

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

std::string Counters::quality_text() const {
    std::string s = std::to_string(quality_ok) + " ok";
    for (int b = 0; b < 5; ++b)
        if (quality_flagged[b]) s += ", " + std::to_string(quality_flagged[b]) + " " + lf_quality_name(1u << b);
    return s;
}

void Bridge::flush_outbox() {
    std::vector<Outgoing> out;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        out.swap(outbox_);
    }
    for (const Outgoing &o : out) {
        // The ego-motion and the quality first: a consumer (and --replay, which counts results)
        // that has the flow then has its ego-motion and quality too.
        if (lcm_publish(lcm_, config_.ego_channel.c_str(), o.ego_bytes.data(), static_cast<unsigned>(o.ego_bytes.size())) !=
            0) {
            std::lock_guard<std::mutex> lock(mutex_);
            counters_.last_error = "publishing on " + config_.ego_channel + " failed";
            log("publishing %zu bytes on %s failed", o.ego_bytes.size(), config_.ego_channel.c_str());
        }
        if (lcm_publish(lcm_, config_.quality_channel.c_str(), o.quality_bytes.data(),
                        static_cast<unsigned>(o.quality_bytes.size())) != 0) {
            std::lock_guard<std::mutex> lock(mutex_);
            counters_.last_error = "publishing on " + config_.quality_channel + " failed";
            log("publishing %zu bytes on %s failed", o.quality_bytes.size(), config_.quality_channel.c_str());
        }
        const int rc = lcm_publish(lcm_, config_.flow_channel.c_str(), o.bytes.data(),
                                   static_cast<unsigned>(o.bytes.size()));
        if (rc == 0) publish_mac(config_.flow_channel, o.bytes.data(), o.bytes.size());
        const double latency_ms = 1000.0 * (monotonic_seconds() - o.received_seconds);
        std::lock_guard<std::mutex> lock(mutex_);
        if (rc != 0) {
            counters_.last_error = "publishing on " + config_.flow_channel + " failed";
            log("publishing %zu bytes on %s failed", o.bytes.size(), config_.flow_channel.c_str());
            continue;
        }
        ++counters_.results_published;
        if (o.quality_flags == 0) ++counters_.quality_ok;
        for (int b = 0; b < 5; ++b) counters_.quality_flagged[b] += (o.quality_flags >> b) & 1u;
        const double n = static_cast<double>(counters_.results_published);
        latency_sum_ms_ += latency_ms;
        compute_sum_ms_ += 1000.0 * o.compute_seconds;
        counters_.latency_last_ms = latency_ms;
        counters_.latency_mean_ms = latency_sum_ms_ / n;
        counters_.latency_max_ms = std::max(counters_.latency_max_ms, latency_ms);
        counters_.compute_last_ms = 1000.0 * o.compute_seconds;
        counters_.compute_mean_ms = compute_sum_ms_ / n;
        if (config_.verbose)  // asked for: a line per result, never held back
            log_each("published scene flow (%zu bytes), latency %.1f ms, estimator %.1f ms", o.bytes.size(), latency_ms,
                1000.0 * o.compute_seconds);
    }
}

void Bridge::publish_status() {
    const Counters c = counters();
    lidarflow_status_t s;
    std::memset(&s, 0, sizeof s);
    s.utime = wall_utime();
    s.uptime_seconds = monotonic_seconds() - start_seconds_;
    s.stereo_received = c.stereo_received;
    s.stereo_lost_in_transport = c.stereo_lost_in_transport;
    s.stereo_processed = c.stereo_processed;
    s.results_published = c.results_published;
    s.frames_with_lidar = c.frames_with_lidar;
    s.dropped_stale = c.dropped_stale;
    s.dropped_out_of_order = c.dropped_out_of_order;
    s.dropped_no_calibration = c.dropped_no_calibration;
    s.dropped_calibration_mismatch = c.dropped_calibration_mismatch;
    s.dropped_malformed = c.dropped_malformed;
    s.dropped_estimator_error = c.dropped_estimator_error;
    s.dropped_shutdown = c.dropped_shutdown;
    s.dropped_unpaired = c.dropped_unpaired;
    s.skipped_other_shard = c.skipped_other_shard;
    s.shard_index = config_.shard_index;
    s.shard_count = config_.shard_count;
    s.shards_dead = c.shards_dead;
    s.pairs_lost_dead_shard = c.pairs_lost_dead_shard;
    s.instance_id = instance_id_;
    s.shard_index_conflicts = c.shard_index_conflicts;
    s.shard_results_ignored = c.shard_results_ignored;
    s.shard_messages_refused = c.shard_messages_refused;
    s.pairs_lost_calibration_change = c.pairs_lost_calibration_change;
    s.lidar_received = c.lidar_received;
    s.lidar_malformed = c.lidar_malformed;
    s.lidar_rejected = c.lidar_rejected;
    s.calibration_received = c.calibration_received;
    s.calibration_malformed = c.calibration_malformed;
    s.queue_depth = c.queue_depth;
    s.queue_capacity = c.queue_capacity;
    s.busy = c.busy ? 1 : 0;
    s.latency_last_ms = static_cast<float>(c.latency_last_ms);
    s.latency_mean_ms = static_cast<float>(c.latency_mean_ms);
    s.latency_max_ms = static_cast<float>(c.latency_max_ms);
    s.compute_last_ms = static_cast<float>(c.compute_last_ms);
    s.compute_mean_ms = static_cast<float>(c.compute_mean_ms);
    std::string last_error = c.last_error;
    s.last_error = &last_error[0];
    std::vector<uint8_t> bytes(static_cast<size_t>(lidarflow_status_t_encoded_size(&s)));
    if (lidarflow_status_t_encode(bytes.data(), 0, static_cast<int>(bytes.size()), &s) != static_cast<int>(bytes.size()) ||
        lcm_publish(lcm_, config_.status_channel.c_str(), bytes.data(), static_cast<unsigned>(bytes.size())) != 0) {
        log("publishing the status on %s failed", config_.status_channel.c_str());
        return;
    }
    publish_mac(config_.status_channel, bytes.data(), bytes.size());
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.status_published;
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
        counters_.dropped_shutdown += static_cast<int64_t>(queue_.size());
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
