// SPDX-License-Identifier: MIT
#pragma once
// How much the CLI says: --quiet (errors only) and --verbose (more detail), accepted by every
// sub-command (main.cpp takes them off the command line before the sub-command parses it).
// Errors never go through here: main prints them whatever the level.
#include <chrono>
#include <string>

#include "progress.hpp"  // format_duration, Progress

namespace lidarflow::cli {

enum class Verbosity { Quiet, Normal, Verbose };

Verbosity verbosity();
void set_verbosity(Verbosity v);
inline bool verbose() { return verbosity() == Verbosity::Verbose; }

// Progress and notes on stderr: note() unless --quiet, detail() with --verbose only.
void note(const char *format, ...) __attribute__((format(printf, 1, 2)));
void detail(const char *format, ...) __attribute__((format(printf, 1, 2)));

// Seconds since construction.
class Stopwatch {
public:
    double seconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    }

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace lidarflow::cli
