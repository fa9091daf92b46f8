// SPDX-License-Identifier: MIT
#pragma once
// Shared by the fuzz targets whose code under test reads files: the input goes to one file per
// process (the readers take paths), in $TMPDIR, else /dev/shm (memory: thousands of writes a
// second), else /tmp.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace lidarflow::fuzz {

inline const std::string &scratch_path(const char *suffix) {
    static const std::string path = [suffix] {
        const char *dir = std::getenv("TMPDIR");
        if (!dir || !*dir) dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
        return std::string(dir) + "/lidarflow_fuzz_" + std::to_string(getpid()) + suffix;
    }();
    return path;
}

// Writes the input to the scratch file; aborts when it cannot (the run would test nothing).
inline const std::string &write_scratch(const uint8_t *data, size_t size, const char *suffix) {
    const std::string &path = scratch_path(suffix);
    std::FILE *f = std::fopen(path.c_str(), "wb");
    if (!f || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
        std::perror(path.c_str());
        std::abort();
    }
    return path;
}

}  // namespace lidarflow::fuzz
