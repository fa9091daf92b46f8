// SPDX-License-Identifier: MIT
#pragma once
// The exception firewall of the C ABI: every lf_ function body runs inside guarded(), which
// turns whatever the C++ core throws into a status code plus a message, so no exception ever
// crosses the extern "C" boundary.
#include <cstdint>
#include <exception>
#include <new>
#include <string>

#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "core/error_of.hpp"
#include "lidarflow/lidarflow.h"

// guarded() returns the core's ErrorCode values as they are: they must be the statuses.
static_assert(LF_ERR_INVALID_ARGUMENT == static_cast<int>(lidarflow::ErrorCode::InvalidArgument) &&
                  LF_ERR_SIZE_MISMATCH == static_cast<int>(lidarflow::ErrorCode::SizeMismatch) &&
                  LF_ERR_IO == static_cast<int>(lidarflow::ErrorCode::Io) &&
                  LF_ERR_FORMAT == static_cast<int>(lidarflow::ErrorCode::Format) &&
                  LF_ERR_BAD_STATE == static_cast<int>(lidarflow::ErrorCode::BadState) &&
                  LF_ERR_NOT_READY == static_cast<int>(lidarflow::ErrorCode::NotReady) &&
                  LF_ERR_OUT_OF_MEMORY == static_cast<int>(lidarflow::ErrorCode::OutOfMemory) &&
                  LF_ERR_INTERNAL == static_cast<int>(lidarflow::ErrorCode::Internal),
              "lf_status_t and ErrorCode must agree");

namespace lidarflow::capi {

// Where a failed call's message goes besides the calling thread's lf_last_error(NULL): the
// handle's own message string, or nullptr for calls without a handle.
class ErrorSink {
public:
    explicit ErrorSink(std::string *handle_message) : handle_(handle_message) {}
    // Clears the handle's message at the start of a call (a successful call leaves "").
    void begin() const {
        if (handle_) handle_->clear();
    }
    // Records `message` for the handle and the thread; returns status.
    int32_t fail(int32_t status, const std::string &message) const;

private:
    std::string *handle_;
};

// The calling thread's last error message ("" when none); lives until the thread ends.
const std::string &thread_last_error();

// Runs body() (which returns an lf_status_t value) and maps exceptions:
// lidarflow::Error -> its code, std::bad_alloc and OpenCV's StsNoMem -> LF_ERR_OUT_OF_MEMORY, anything else ->
// LF_ERR_INTERNAL. Never throws.
template <class Body>
int32_t guarded(const ErrorSink &sink, const char *function, Body &&body) noexcept {
    try {
        sink.begin();
        return body();
    } catch (...) {
        const Error e = error_of_current_exception(function);
        return sink.fail(static_cast<int32_t>(e.code()), e.what());
    }
}

// Throws Error(InvalidArgument, "<what> is NULL") when p is null.
inline void require_non_null(const void *p, const char *what) {
    require(p != nullptr, ErrorCode::InvalidArgument, std::string(what) + " is NULL");
}

// Checks the struct_size of a caller struct whose current layout has `known` bytes: smaller is
// an error (an older layout than the first one does not exist); larger is accepted only when
// the bytes this library does not know are all zero (a newer caller that does not use the new
// fields). Throws Error(InvalidArgument).
void check_struct_size(const void *s, uint32_t struct_size, size_t known, const char *what);

}  // namespace lidarflow::capi
