// SPDX-License-Identifier: MIT
// lf_set_log_callback: the C ABI's door to the core's process-wide message sink (core/log.hpp).
#include <string>

#include "core/log.hpp"
#include "guard.hpp"

using lidarflow::ErrorCode;
using lidarflow::require;
using namespace lidarflow::capi;

extern "C" {

LF_API int32_t lf_set_log_callback(lf_log_fn fn, int32_t min_level, void *user) {
    return guarded(ErrorSink(nullptr), "lf_set_log_callback", [&] {
        require(!fn || (min_level >= LF_LOG_DEBUG && min_level <= LF_LOG_ERROR), ErrorCode::InvalidArgument,
                "min_level " + std::to_string(min_level) + " is outside [LF_LOG_DEBUG (10), LF_LOG_ERROR (40)]");
        lidarflow::log::set_sink(fn, min_level, user);
        return static_cast<int32_t>(LF_OK);
    });
}

}  // extern "C"
