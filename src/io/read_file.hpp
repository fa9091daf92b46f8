// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <string>

namespace lidarflow::io {

// Text files (calibration, timestamps, annotations) are read whole: at most this many bytes.
constexpr uint64_t kMaxTextFileBytes = uint64_t{64} << 20;

// The whole file as bytes. Only a regular file is opened, without blocking (core/regular_file.hpp:
// a FIFO or device is refused, not waited on). Error(Io) "cannot open PATH: WHY" when it cannot be
// opened, is not a regular file, holds more than `max_bytes` or cannot be read.
std::string read_file(const std::string &path, uint64_t max_bytes = UINT64_MAX);

}  // namespace lidarflow::io
