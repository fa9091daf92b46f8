// SPDX-License-Identifier: MIT
#include "guard.hpp"

namespace lidarflow::capi {
namespace {

std::string &thread_message() {
    // One string per thread: lf_last_error(NULL) must not race between threads.
    thread_local std::string message;
    return message;
}

}  // namespace

const std::string &thread_last_error() { return thread_message(); }

int32_t ErrorSink::fail(int32_t status, const std::string &message) const {
    // Assigning may itself run out of memory; the status still gets through.
    try {
        thread_message() = message;
        if (handle_) *handle_ = message;
    } catch (...) {
    }
    return status;
}

void check_struct_size(const void *s, uint32_t struct_size, size_t known, const char *what) {
    require(struct_size >= known, ErrorCode::InvalidArgument,
            std::string(what) + ".struct_size is " + std::to_string(struct_size) + ", expected " +
                std::to_string(known) + " (initialise it with sizeof or the lf_*_init helper)");
    const unsigned char *bytes = static_cast<const unsigned char *>(s);
    for (size_t i = known; i < struct_size; ++i)
        require(bytes[i] == 0, ErrorCode::InvalidArgument,
                std::string(what) + " has non-zero fields this library version does not know (struct_size " +
                    std::to_string(struct_size) + ", known " + std::to_string(known) + ")");
}

}  // namespace lidarflow::capi
