// SPDX-License-Identifier: MIT
#pragma once
// How --shard processes vouch for what they publish: a MAC under a shared key, or without one a
// receipt naming the process (see docs/LCM.md, "What the watch trusts"). Pure functions; any thread.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lidarflow::bridge {

// The MAC message that follows a shard's `payload` on `channel` with --shard-key: 8 bytes
// "LFMAC\x01\0\0", shard index and count (int32, big-endian), and HMAC-SHA256(key, "lidarflow
// shard mac v1\0" index count channel "\0" payload) (32 bytes). Empty when libcrypto fails.
std::vector<uint8_t> shard_mac_message(const std::string &key, int32_t index, int32_t count,
                                       const std::string &channel, const void *payload, size_t size);
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
