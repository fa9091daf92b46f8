// SPDX-License-Identifier: MIT
#pragma once
// Wire helpers shared by the bridge's decoders (wire.cpp, wire_bot_core.cpp); not an interface.
#include <cstdint>

namespace lidarflow::bridge::detail {

// A big-endian integer of `bytes` (1..8) bytes, sign-extended (LCM encodes integers so).
int64_t read_be(const uint8_t *p, int bytes);

// Bytes per pixel of a stereo_t pixel_format; 0 for an unknown one.
int bytes_per_pixel(int8_t format);

}  // namespace lidarflow::bridge::detail
