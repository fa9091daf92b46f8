// SPDX-License-Identifier: MIT
#pragma once
// Wire helpers shared by the bridge's decoders and encoders (wire.cpp, wire_bot_core.cpp, log_reader.cpp,
// shard_auth.cpp, ...); not an interface.
#include <cstdint>

namespace lidarflow::bridge::detail {

// A big-endian integer of `bytes` (1..8) bytes, sign-extended (LCM encodes integers so).
int64_t read_be(const uint8_t *p, int bytes);

// Writes the low `bytes` (1..8) bytes of v big-endian.
void write_be(uint8_t *p, uint64_t v, int bytes);

// Bytes per pixel of a stereo_t pixel_format; 0 for an unknown one.
int bytes_per_pixel(int8_t format);

}  // namespace lidarflow::bridge::detail
