// SPDX-License-Identifier: MIT
#include "log.hpp"

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

}  // namespace lidarflow::cli
