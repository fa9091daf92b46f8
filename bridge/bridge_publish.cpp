// SPDX-License-Identifier: MIT
// What the bridge publishes: results with their ego-motion, the status heartbeat, and the
// --shard MAC or receipt after each.
#include <algorithm>
#include <chrono>
#include <cstring>

#include "bridge_core.hpp"
#include "lidarflow_status_t.h"
#include "wire_detail.hpp"

namespace lidarflow::bridge {
namespace {

int64_t wall_utime() {
    return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

}  // namespace

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
    // False, with the failure noted, when LCM refused the message.
    auto publish = [this](const std::string &channel, const std::vector<uint8_t> &bytes) {
        if (lcm_publish(lcm_, channel.c_str(), bytes.data(), static_cast<unsigned>(bytes.size())) == 0) return true;
        std::lock_guard<std::mutex> lock(mutex_);
        counters_.last_error = "publishing on " + channel + " failed";
        log("publishing %zu bytes on %s failed", bytes.size(), channel.c_str());
        return false;
    };
    for (const Outgoing &o : out) {
        // The ego-motion and the quality first: a consumer (and --replay, which counts results)
        // that has the flow then has its ego-motion and quality too.
        publish(config_.ego_channel, o.ego_bytes);
        publish(config_.quality_channel, o.quality_bytes);
        if (!publish(config_.flow_channel, o.bytes)) continue;
        int64_t t1 = 0;
        scene_flow_utime(o.bytes.data(), o.bytes.size(), &t1);
        publish_mac(config_.flow_channel, o.bytes.data(), o.bytes.size(), ShardMacKind::Result, t1);
        const double latency_ms = 1000.0 * (monotonic_seconds() - o.received_seconds);
        std::lock_guard<std::mutex> lock(mutex_);
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
    publish_mac(config_.status_channel, bytes.data(), bytes.size(), ShardMacKind::Status, s.utime);
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.status_published;
}

void Bridge::publish_mac(const std::string &channel, const void *payload, size_t size, ShardMacKind kind,
                         int64_t utime) {
    if (config_.shard_count < 2) return;
    // Without a key only results get a receipt: a status names its process itself.
    if (config_.shard_key.empty() && kind != ShardMacKind::Result) return;
    std::vector<uint8_t> m;
    if (config_.shard_key.empty()) {
        m = shard_receipt_message(config_.shard_index, config_.shard_count, instance_id_, channel, payload, size);
    } else {
        std::vector<uint64_t> echoes(static_cast<size_t>(config_.shard_count), 0);
        {
            std::lock_guard<std::mutex> lock(mutex_);
            for (size_t k = 0; k < echoes_.size(); ++k) echoes[k] = echoes_[k].tag;
        }
        m = shard_mac_message(config_.shard_key, kind, config_.shard_index, config_.shard_count, utime, instance_id_,
                              echoes, channel, payload, size);
    }
    if (m.empty() || lcm_publish(lcm_, config_.shard_auth_channel.c_str(), m.data(), static_cast<unsigned>(m.size())) != 0) {
        log("publishing the MAC of a message on %s failed", channel.c_str());
        return;
    }
    if (config_.shard_key.empty() || kind != ShardMacKind::Status || shard_timeout_ <= 0) return;
    // The tag the other shards echo: a status of theirs that holds it was sent after this one.
    const uint64_t tag = static_cast<uint64_t>(detail::read_be(&m[m.size() - 32], 8));
    const double now = monotonic_seconds();
    std::lock_guard<std::mutex> lock(mutex_);
    own_tags_.emplace_back(tag, now);
    while (!own_tags_.empty() && (now - own_tags_.front().second > shard_timeout_ || own_tags_.size() > 4096))
        own_tags_.pop_front();
}

}  // namespace lidarflow::bridge
