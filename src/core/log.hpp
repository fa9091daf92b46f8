// SPDX-License-Identifier: MIT
#pragma once
// The library's messages (lf_set_log_callback in the C ABI): one process-wide sink with a
// minimum level, silent until a sink is set. The core says what it decided (points dropped,
// fallbacks, reuse refused); the caller's frame context is prefixed from a thread-local scope.
#include <cstdint>
#include <string>

namespace lidarflow::log {

// Numbered like lf_log_level_t and Python's logging levels.
enum class Level { Debug = 10, Info = 20, Warning = 30, Error = 40 };

using Sink = void (*)(int32_t level, const char *message, void *user);  // lf_log_fn

// Replaces the sink (nullptr: silent). Messages below min_level are not formatted. When it
// returns, no call of an earlier sink is running on another thread, so the caller may free the
// old `user`; called from inside a sink it does not wait (that call is its own). Thread-safe.
void set_sink(Sink fn, int min_level, void *user);

// Whether a message of `level` would reach the sink now (one atomic load). Thread-safe.
bool enabled(Level level);

// Sends "<scope>: message" (or the message alone outside any scope) to the sink, if any, from
// the calling thread, holding no lock of the library. Thread-safe; never throws.
void write(Level level, const std::string &message);

// While alive, prefixes the calling thread's messages with `context` (e.g. "estimator 0x55...,
// frame 2000 us"); scopes nest, the innermost wins. Not movable.
class Scope {
public:
    explicit Scope(std::string context);
    ~Scope();
    Scope(const Scope &) = delete;
    Scope &operator=(const Scope &) = delete;

private:
    std::string previous_;
};

}  // namespace lidarflow::log
