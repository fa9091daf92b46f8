// SPDX-License-Identifier: MIT
#include "io/output_folder.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "core/error.hpp"

namespace lidarflow::io {

void prepare_output_folder(const std::string &dir) {
    require(!dir.empty(), ErrorCode::InvalidArgument, "output folder: empty path");
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::create_directories(dir, ec);
    require(!ec, ErrorCode::Io, "cannot create output folder " + dir + ": " + ec.message());
    require(fs::is_directory(dir, ec), ErrorCode::Io, "cannot create output folder " + dir + ": not a folder");
    // Creating a file is the test that counts: access(W_OK) says yes to root whatever the
    // permission bits, and knows nothing of ACL or security-module denials.
    const std::string probe = (fs::path(dir) / ".lidarflow-write-test-XXXXXX").string();
    std::vector<char> name(probe.begin(), probe.end());
    name.push_back('\0');
    const int fd = mkstemp(name.data());
    require(fd >= 0, ErrorCode::Io, [&] { return "cannot write to output folder " + dir + ": " + std::strerror(errno); });
    close(fd);
    unlink(name.data());
}

}  // namespace lidarflow::io
