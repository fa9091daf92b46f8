// SPDX-License-Identifier: MIT
#include "io/read_file.hpp"

#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace lidarflow::io {

std::string read_file(const std::string &path) {
    std::ifstream in(path, std::ios::binary);
    require(in.good(), ErrorCode::Io, "cannot open " + path);
    std::ostringstream ss;
    ss << in.rdbuf();
    require(!in.bad(), ErrorCode::Io, "cannot read " + path);
    return ss.str();
}

}  // namespace lidarflow::io
