// SPDX-License-Identifier: MIT
#pragma once
// Inputs that must be regular files. An open(2) of a FIFO waits for a writer and a read of a
// device (/dev/zero) never ends, so every reader of a named input opens it here: without
// blocking (O_NONBLOCK) and only when fstat says it is a regular file, and reads it with a bound.
#include <cstdint>
#include <string>

namespace lidarflow {

// An open, read-only regular file. Owns its descriptor (closed by the destructor); not copyable;
// one object per thread. Never throws, so that core code that must not fail (threads_for_now)
// can use it.
class RegularFile {
public:
    explicit RegularFile(const char *path) noexcept;
    explicit RegularFile(const std::string &path) noexcept : RegularFile(path.c_str()) {}
    ~RegularFile();
    RegularFile(const RegularFile &) = delete;
    RegularFile &operator=(const RegularFile &) = delete;

    bool ok() const noexcept { return fd_ >= 0; }
    // Why the file is not open (or not read): "missing", "is a folder", "is a FIFO, not a regular
    // file", "larger than N bytes", an strerror text, ... ("" when ok and read).
    std::string error() const;
    bool missing() const noexcept { return missing_; }
    int fd() const noexcept { return fd_; }
    // The size fstat gave (0 for /proc files, which are read to their end instead).
    uint64_t size() const noexcept { return size_; }

    // Reads from the start to the end into `out`; false, with error() set and `out` cleared, when
    // the file is larger than `max_bytes` (told by its size, before anything is allocated, or
    // while reading) or a read fails.
    bool read_all(std::string &out, uint64_t max_bytes) noexcept;

private:
    int fd_ = -1;
    uint64_t size_ = 0;
    bool missing_ = false;
    const char *why_ = "";  // a static text; with errno_ when that is set
    int errno_ = 0;
    uint64_t limit_ = 0;  // the bound that read_all exceeded, for error()
};

}  // namespace lidarflow
