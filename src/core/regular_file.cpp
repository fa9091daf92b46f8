// SPDX-License-Identifier: MIT
#include "core/regular_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <new>

namespace lidarflow {
namespace {

const char *kind_text(mode_t mode) {
    if (S_ISDIR(mode)) return "is a folder, not a regular file";
    if (S_ISFIFO(mode)) return "is a FIFO, not a regular file";
    if (S_ISCHR(mode)) return "is a character device, not a regular file";
    if (S_ISBLK(mode)) return "is a block device, not a regular file";
    if (S_ISSOCK(mode)) return "is a socket, not a regular file";
    return "is not a regular file";
}

}  // namespace

RegularFile::RegularFile(const char *path) noexcept {
    const int fd = ::open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        missing_ = errno == ENOENT;
        why_ = missing_ ? "missing" : "";  // the strerror text says it
        if (!missing_) errno_ = errno;
        return;
    }
    struct stat st {};
    if (::fstat(fd, &st) != 0) {
        errno_ = errno;
        why_ = "cannot stat";
        ::close(fd);
        return;
    }
    if (!S_ISREG(st.st_mode)) {
        why_ = kind_text(st.st_mode);
        ::close(fd);
        return;
    }
    // Reads of a regular file do not block anyway; blocking mode keeps read(2) plain.
    const int flags = ::fcntl(fd, F_GETFL);
    if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    fd_ = fd;
    size_ = static_cast<uint64_t>(st.st_size);
}

RegularFile::~RegularFile() {
    if (fd_ >= 0) ::close(fd_);
}

std::string RegularFile::error() const {
    std::string e = why_;
    if (errno_ != 0) e += (e.empty() ? "" : ": ") + std::string(std::strerror(errno_));
    if (limit_ != 0) e += " " + std::to_string(limit_) + " bytes";
    return e;
}

bool RegularFile::read_all(std::string &out, uint64_t max_bytes) noexcept {
    out.clear();
    if (fd_ < 0) return false;
    const auto too_large = [&] {
        out.clear();
        why_ = "is larger than";
        limit_ = max_bytes;
        return false;
    };
    if (size_ > max_bytes) return too_large();
    try {
        out.resize(static_cast<size_t>(size_));
        size_t got = 0;
        for (;;) {
            if (got == out.size()) {
                // At the size fstat gave (0 for /proc files): read on until the end, in the bound.
                if (out.size() > max_bytes) return too_large();
                out.resize(got + 4096);
            }
            const ssize_t n = ::pread(fd_, &out[got], out.size() - got, static_cast<off_t>(got));
            if (n < 0) {
                if (errno == EINTR) continue;
                errno_ = errno;
                why_ = "cannot read";
                out.clear();
                return false;
            }
            if (n == 0) break;
            got += static_cast<size_t>(n);
        }
        out.resize(got);
        if (got > max_bytes) return too_large();
    } catch (const std::bad_alloc &) {
        why_ = "cannot read: out of memory";
        out.clear();
        return false;
    }
    return true;
}

}  // namespace lidarflow
