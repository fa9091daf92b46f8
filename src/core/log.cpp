// SPDX-License-Identifier: MIT
#include "core/log.hpp"

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace lidarflow::log {
namespace {

struct State {
    std::mutex mutex;
    std::condition_variable idle;
    Sink fn = nullptr;
    void *user = nullptr;
    uint64_t generation = 0;  // bumped by each set_sink
    int current_calls = 0;    // running calls of the current sink
    int older_calls = 0;      // running calls of replaced sinks, which set_sink waits for
};

State &state() {
    static State s;
    return s;
}

// INT32_MAX: silent. Read without the lock, so that a disabled level costs one load.
std::atomic<int> g_min_level{INT32_MAX};

thread_local std::string t_context;
thread_local bool t_in_sink = false;

}  // namespace

void set_sink(Sink fn, int min_level, void *user) {
    State &s = state();
    std::unique_lock<std::mutex> lock(s.mutex);
    s.fn = fn;
    s.user = user;
    ++s.generation;
    s.older_calls += s.current_calls;
    s.current_calls = 0;
    g_min_level.store(fn ? min_level : INT32_MAX, std::memory_order_relaxed);
    if (!t_in_sink) s.idle.wait(lock, [&] { return s.older_calls == 0; });
}

bool enabled(Level level) { return static_cast<int>(level) >= g_min_level.load(std::memory_order_relaxed); }

void write(Level level, const std::string &message) {
    if (!enabled(level) || t_in_sink) return;  // a sink's own library calls do not log into it
    try {
        const std::string text = t_context.empty() ? message : t_context + ": " + message;
        State &s = state();
        Sink fn;
        void *user;
        uint64_t generation;
        {
            std::lock_guard<std::mutex> lock(s.mutex);
            if (!s.fn || static_cast<int>(level) < g_min_level.load(std::memory_order_relaxed)) return;
            fn = s.fn;
            user = s.user;
            generation = s.generation;
            ++s.current_calls;
        }
        // Ends the call's accounting even if a C++ sink throws, or set_sink would wait forever.
        struct Done {
            State &s;
            uint64_t generation;
            ~Done() {
                t_in_sink = false;
                std::lock_guard<std::mutex> lock(s.mutex);
                if (generation == s.generation) {
                    --s.current_calls;
                } else if (--s.older_calls == 0) {
                    s.idle.notify_all();
                }
            }
        } done{s, generation};
        t_in_sink = true;
        fn(static_cast<int32_t>(level), text.c_str(), user);
    } catch (...) {
        // A message that cannot be built (out of memory) is dropped: logging never fails a frame.
    }
}

Scope::Scope(std::string context) : previous_(std::move(t_context)) { t_context = std::move(context); }

Scope::~Scope() { t_context = std::move(previous_); }

}  // namespace lidarflow::log
