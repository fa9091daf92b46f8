// SPDX-License-Identifier: MIT
#pragma once
// Progress of long runs on stderr, shared by the CLI (kitti, publish-kitti) and the bridge's
// --replay: elapsed time and the time left. On a terminal one line is rewritten in place; piped
// (CI logs, `| tee`) plain lines, so a log shows where a run is without control characters.
#include <chrono>
#include <string>

namespace lidarflow::cli {

// "12.3 s", "4:05", "1:02:03"; "?" for a negative or non-finite duration.
std::string format_duration(double seconds);

class Progress {
public:
    // enabled: false prints nothing (--quiet). terminal: rewrite one line (normally
    // isatty(stderr)). piped_period_s: piped, at most one line per this many seconds besides the
    // first and the last step (0: a line per step).
    Progress(bool enabled, bool terminal, double piped_period_s);

    // `done` of `total` units of work are finished (frames, bytes: any unit; total <= 0: unknown,
    // no ETA); `what` names the current step, e.g. "[3/10] 000004". The line reads
    // "WHAT  (elapsed T, ETA T)"; ETA is the elapsed time per unit done times the units left.
    void update(double done, double total, const std::string &what);

    // Ends the rewritten terminal line (nothing when piped). Idempotent.
    void finish();

    // Seconds since construction.
    double seconds() const;

private:
    bool enabled_, terminal_, open_line_ = false;
    double period_, last_piped_ = -1e300;
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace lidarflow::cli
