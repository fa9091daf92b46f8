// SPDX-License-Identifier: MIT
#include "progress.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lidarflow::cli {

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

Progress::Progress(bool enabled, bool terminal, double piped_period_s)
    : enabled_(enabled), terminal_(terminal), period_(piped_period_s) {}

double Progress::seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::update(double done, double total, const std::string &what) {
    if (!enabled_) return;
    const double now = seconds();
    const bool last = total > 0 && done >= total;
    if (!terminal_ && !(now - last_piped_ >= period_ || last || last_piped_ < -1e299)) return;
    const std::string eta = done > 0 && total > 0 ? format_duration(now / done * std::max(0.0, total - done))
                                                  : std::string("--");
    if (terminal_) {
        std::fprintf(stderr, "\r\033[K%s  (elapsed %s, ETA %s)", what.c_str(), format_duration(now).c_str(), eta.c_str());
        open_line_ = true;
    } else {
        std::fprintf(stderr, "%s  (elapsed %s, ETA %s)\n", what.c_str(), format_duration(now).c_str(), eta.c_str());
        last_piped_ = now;
    }
    std::fflush(stderr);
}

void Progress::finish() {
    if (!open_line_) return;
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    open_line_ = false;
}

}  // namespace lidarflow::cli
