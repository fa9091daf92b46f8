// SPDX-License-Identifier: MIT
#include "io/read_file.hpp"

#include "core/error.hpp"
#include "core/regular_file.hpp"

namespace lidarflow::io {

std::string read_file(const std::string &path, uint64_t max_bytes) {
    RegularFile f(path);
    std::string data;
    require(f.read_all(data, max_bytes), ErrorCode::Io, [&] { return "cannot open " + path + ": " + f.error(); });
    return data;
}

}  // namespace lidarflow::io
