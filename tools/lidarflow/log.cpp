// SPDX-License-Identifier: MIT
#include "log.hpp"

#include <cmath>
#include <cstdarg>
#include <cstdio>

namespace lidarflow::cli {
namespace {
Verbosity g_verbosity = Verbosity::Normal;

void vprint(const char *format, va_list ap) {
    std::vfprintf(stderr, format, ap);
    std::fflush(stderr);
}
}  // namespace

Verbosity verbosity() { return g_verbosity; }
void set_verbosity(Verbosity v) { g_verbosity = v; }

void note(const char *format, ...) {
    if (g_verbosity == Verbosity::Quiet) return;
    va_list ap;
    va_start(ap, format);
    vprint(format, ap);
    va_end(ap);
}

void detail(const char *format, ...) {
    if (g_verbosity != Verbosity::Verbose) return;
    va_list ap;
    va_start(ap, format);
    vprint(format, ap);
    va_end(ap);
}

std::string format_duration(double seconds) {
    char buf[32];
    if (!std::isfinite(seconds) || seconds < 0) return "?";
    if (seconds < 60) {
        std::snprintf(buf, sizeof buf, "%.1f s", seconds);
        return buf;
    }
    const long s = std::lround(seconds);
    if (s < 3600)
        std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
    else
        std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
    return buf;
}

}  // namespace lidarflow::cli
