// SPDX-License-Identifier: MIT
#pragma once
// The one exception type of the core. The C ABI maps ErrorCode 1:1 onto lf_status_t, so the
// numeric values here must equal those in include/lidarflow/lidarflow.h.
#include <stdexcept>
#include <string>
#include <type_traits>

namespace lidarflow {

enum class ErrorCode : int {
    InvalidArgument = 1,
    SizeMismatch = 2,
    Io = 3,
    Format = 4,
    BadState = 5,
    NotReady = 6,
    OutOfMemory = 7,
    Internal = 8,
};

class Error : public std::runtime_error {
public:
    Error(ErrorCode code, const std::string &message) : std::runtime_error(message), code_(code) {}
    ErrorCode code() const noexcept { return code_; }

private:
    ErrorCode code_;
};

// Throws Error(code, message) when cond is false. For argument and data validation, not for
// internal invariants.
inline void require(bool cond, ErrorCode code, const std::string &message) {
    if (!cond) throw Error(code, message);
}
// Why these overloads: checks run per pixel or per point in places, and building a
// std::string message for every passing check was a measurable share of stage 2's time.
inline void require(bool cond, ErrorCode code, const char *message) {
    if (!cond) throw Error(code, message);
}
// make_message() is called only when the check fails.
template <class F, class = std::enable_if_t<std::is_invocable_r_v<std::string, F>>>
inline void require(bool cond, ErrorCode code, F &&make_message) {
    if (!cond) throw Error(code, make_message());
}

}  // namespace lidarflow
