// SPDX-License-Identifier: MIT
#pragma once
#include <string>

namespace lidarflow::io {

// The whole file as bytes. Error(Io) when it cannot be opened or read.
std::string read_file(const std::string &path);

}  // namespace lidarflow::io
