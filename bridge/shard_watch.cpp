// SPDX-License-Identifier: MIT
// The --shard watch: the other shards' heartbeats (status_t), their results on the flow
// channel, and the MACs or receipts that make either count.
#include <algorithm>
#include <cinttypes>
#include <cstring>

#include "bridge_core.hpp"
#include "wire_detail.hpp"

namespace lidarflow::bridge {

void Bridge::on_status(const lcm_recv_buf_t *rbuf, const char *, void *self) {
    auto *b = static_cast<Bridge *>(self);
    StatusMessage status;
    if (!decode_status(rbuf->data, rbuf->data_size, status).empty()) return;  // not ours to judge
    const lidarflow_status_t &f = status.fields;
    // Computed before the lock: a digest costs a pass over the message.
    const bool ours = f.shard_count == b->config_.shard_count && f.shard_index >= 0 && f.shard_index < f.shard_count &&
                      f.shard_index != b->config_.shard_index;
    Digest digest{};
    const bool keyed = !b->config_.shard_key.empty();
    if (ours && keyed && !message_digest(rbuf->data, rbuf->data_size, &digest)) return;
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
    const double now = monotonic_seconds();
    if (!keyed) {
        b->apply_status_locked(f.shard_index, f.utime, f.instance_id, now);
        return;
    }
    // Its MAC, when valid, already did what the status asks; here it is only told apart from a
    // status that no MAC vouches for (counted when none comes).
    std::vector<uint8_t> d(digest.begin(), digest.end());
    if (b->vouched_locked(d, f.shard_index, true)) return;
    b->awaiting_mac_.push_back({true, f.shard_index, f.utime, f.instance_id, std::move(d), now});
    b->expire_macs_locked(now);
}

// A status that counts (authenticated and fresh with --shard-key): the shard is alive, if it comes from
// the process holding the index. The first process heard holds it; another one takes it over
// only once the holder is silent for the timeout (a restart), and never one heard claiming the
// index while the holder lived (a second process or a forger: it must not keep the index alive).
void Bridge::apply_status_locked(int32_t shard, int64_t utime, int64_t instance, double heard_at) {
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
    w.last_heartbeat = std::max(w.last_heartbeat, heard_at);
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
    std::vector<uint8_t> mac;
    if (keyed) {
        // A valid MAC settles the pair alone; the result is only told apart from one that no MAC
        // of its owner vouches for (counted when none comes).
        Digest digest;
        if (!message_digest(rbuf->data, rbuf->data_size, &digest)) return;
        mac.assign(digest.begin(), digest.end());
    } else {
        mac = shard_receipt_message(owner, b->config_.shard_count, 0, b->config_.flow_channel, rbuf->data,
                                    rbuf->data_size);
    }
    lock.lock();
    const double now = monotonic_seconds();
    if (keyed) {
        if (b->vouched_locked(mac, owner, false)) return;
    } else {
        for (auto it = b->received_macs_.begin(); it != b->received_macs_.end(); ++it)
            if (it->mac == mac) {
                const int64_t instance = it->instance;
                b->received_macs_.erase(it);
                b->apply_receipt_locked(owner, utime, instance);
                return;
            }
    }
    b->awaiting_mac_.push_back({false, owner, utime, 0, std::move(mac), now});
    b->expire_macs_locked(now);
}

// --shard-key: whether a valid MAC of `shard` already vouched for the message of this digest
// (forgotten then: one MAC vouches for one message).
bool Bridge::vouched_locked(const std::vector<uint8_t> &digest, int32_t shard, bool status) {
    for (auto it = received_macs_.begin(); it != received_macs_.end(); ++it)
        if (it->mac == digest && it->instance == shard && it->status == status) {
            received_macs_.erase(it);
            return true;
        }
    return false;
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
    if (!b->config_.shard_key.empty()) {
        ShardMac m;
        const std::string why = check_shard_mac(b->config_.shard_key, b->config_.shard_count, b->config_.status_channel,
                                                b->config_.flow_channel, rbuf->data, rbuf->data_size, &m);
        std::lock_guard<std::mutex> lock(b->mutex_);
        if (why.rfind("version 1", 0) == 0 && !b->warned_old_mac_) {
            b->warned_old_mac_ = true;
            b->log("a MAC message of %s on %s: not taken, every shard needs this version", why.c_str(),
                   b->config_.shard_auth_channel.c_str());
        }
        // Its own, looped back, or another process's on this index: no claim the watch judges.
        if (why.empty() && m.index != b->config_.shard_index) b->on_keyed_mac_locked(m, monotonic_seconds());
        return;
    }
    // Without a key, a receipt (a MAC is no proof here).
    if (rbuf->data_size != 48 || std::memcmp(d, "LFRCP\x01\0\0", 8) != 0) return;
    std::vector<uint8_t> mac(d, d + rbuf->data_size);
    const int64_t instance = detail::read_be(&mac[16], 8);
    std::fill(mac.begin() + 16, mac.begin() + 24, 0);  // matched without it, then checked
    std::lock_guard<std::mutex> lock(b->mutex_);
    const double now = monotonic_seconds();
    for (auto it = b->awaiting_mac_.begin(); it != b->awaiting_mac_.end(); ++it)
        if (it->mac == mac) {
            const AwaitingMac m = std::move(*it);
            b->awaiting_mac_.erase(it);
            b->apply_receipt_locked(m.shard, m.utime, instance);
            return;
        }
    b->received_macs_.push_back({std::move(mac), instance, false, now});
    b->expire_macs_locked(now);
}

// A valid MAC of another shard (--shard-key). It carries what the watch needs, so it acts
// whether its message came, comes later or never: a result's settles that shard's pair; a
// status's is a heartbeat when fresh, i.e. when it echoes one of this shard's own status tags
// of the last timeout, which proves it was sent after that status (a recording cannot hold
// tags sent after it was made). The shard then counts as alive as of that status.
void Bridge::on_keyed_mac_locked(const ShardMac &m, double now) {
    const bool status = m.kind == ShardMacKind::Status;
    Echo &e = echoes_[static_cast<size_t>(m.index)];
    if (status && (!e.have || m.utime > e.utime)) e = {true, m.utime, m.tag};  // answered in this one's MACs
    std::vector<uint8_t> digest(m.digest.begin(), m.digest.end());
    bool message_seen = false;
    for (auto it = awaiting_mac_.begin(); it != awaiting_mac_.end(); ++it)
        if (it->mac == digest && it->shard == m.index && it->status == status) {
            awaiting_mac_.erase(it);
            message_seen = true;
            break;
        }
    if (!message_seen) received_macs_.push_back({std::move(digest), m.index, status, now});
    expire_macs_locked(now);
    if (shard_timeout_ <= 0) return;  // no watch: echoes only
    if (!status) {
        apply_flow_locked(m.index, m.utime);
        return;
    }
    const uint64_t echo = m.echoes[static_cast<size_t>(config_.shard_index)];
    for (const auto &[tag, published] : own_tags_)
        if (tag == echo && echo != 0) {
            apply_status_locked(m.index, m.utime, m.instance, published);
            return;
        }
    // No answer to a recent status of this one: a recording, or a shard that has not heard this
    // one yet (counted only once every live shard has had a timeout to hear it).
    if (echo == 0 || now - start_seconds_ <= shard_timeout_) return;
    ++counters_.shard_messages_refused;
    log("a status of shard %d/%d (utime %" PRId64 ") with a valid MAC that answers no status of this shard of the "
        "last %.1f s: a recording played again, ignored",
        m.index, config_.shard_count, m.utime, shard_timeout_);
}

// Messages whose MAC (or receipt) did not come within a second (or a wrong one did) are refused;
// MACs without their message are forgotten. Both lists are bounded: under a flood, the oldest
// waiting messages are counted at once (with a key that decides nothing: a valid MAC acts alone).
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
}  // namespace lidarflow::bridge
