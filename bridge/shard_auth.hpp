// SPDX-License-Identifier: MIT
#pragma once
// How --shard processes vouch for what they publish: a MAC under a shared key, or without one a
// receipt naming the process (see docs/LCM.md, "What the watch trusts"). Pure functions; any thread.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lidarflow::bridge {

// What a shard MAC vouches for: a status_t on the status channel, or a scene_flow_t on the flow
// channel.
enum class ShardMacKind : uint8_t { Status = 1, Result = 2 };

// The MAC message (version 2) that follows a shard's `payload` on `channel` with --shard-key,
// all integers big-endian:
//   0  "LFMAC\x02", kind (1 status, 2 result), 0
//   8  shard index, count (int32)
//  16  utime (int64): status_t.utime, or the result's t1
//  24  instance (int64): the publishing process's status_t.instance_id
//  32  SHA-256(payload) (32 bytes)
//  64  echoes: `count` tags (8 bytes each), slot j the tag of the newest status MAC heard from
//      shard j (0: none); a watcher takes a status as fresh only when its own slot holds one of
//      its own recent tags, which a recording made before it sent them cannot hold
//  64 + 8 count: HMAC-SHA256(key, "lidarflow shard mac v2\0" channel "\0" bytes 0 .. 64 + 8 count)
// The tag of a MAC message is the first 8 bytes of its HMAC. `echoes` has `count` entries, or
// none (all 0). Empty when libcrypto fails.
std::vector<uint8_t> shard_mac_message(const std::string &key, ShardMacKind kind, int32_t index, int32_t count,
                                       int64_t utime, int64_t instance, const std::vector<uint64_t> &echoes,
                                       const std::string &channel, const void *payload, size_t size);

using Digest = std::array<uint8_t, 32>;

// SHA-256 of a message, as a MAC message carries it; false when libcrypto fails.
bool message_digest(const void *payload, size_t size, Digest *out);

// A MAC message read back and verified.
struct ShardMac {
    ShardMacKind kind = ShardMacKind::Status;
    int32_t index = 0, count = 0;
    int64_t utime = 0, instance = 0;
    Digest digest{};
    std::vector<uint64_t> echoes;  // `count` entries
    uint64_t tag = 0;
};

// Reads a version-2 MAC message of a split into `count` shards and checks its HMAC under `key`
// (channel: status_channel or flow_channel by its kind). "" or what is wrong; a version-1 MAC
// (older bridges, no freshness) is refused with a reason starting "version 1".
std::string check_shard_mac(const std::string &key, int32_t count, const std::string &status_channel,
                            const std::string &flow_channel, const void *data, size_t size, ShardMac *out);

// The receipt that follows a shard's result on `channel` without --shard-key: 8 bytes
// "LFRCP\x01\0\0", shard index and count (int32, big-endian), the publishing process's
// instance_id (int64, big-endian), and the first 24 bytes of SHA-256(channel "\0" payload).
// Anyone can make one: it names the process, it does not authenticate it. Empty when libcrypto
// fails.
std::vector<uint8_t> shard_receipt_message(int32_t index, int32_t count, int64_t instance, const std::string &channel,
                                           const void *payload, size_t size);
// Reads a --shard-key file into *key; "" or what is wrong (missing, shorter than 16 bytes).
std::string read_shard_key(const std::string &path, std::string *key);

}  // namespace lidarflow::bridge
