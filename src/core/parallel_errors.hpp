// SPDX-License-Identifier: MIT
#pragma once
// An exception that leaves an OpenMP structured block calls std::terminate, so a
// std::bad_alloc (or a lidarflow::Error) thrown by a worker would abort the whole process
// instead of reaching the C ABI's guard as LF_ERR_OUT_OF_MEMORY. Every parallel loop whose
// body can throw runs it through ParallelErrors::run(); the thread that opened the region
// calls rethrow_if_any() after it, so the first exception continues on the caller's stack.
//
// Rules for regions with a worksharing construct inside (`omp parallel` + `omp for`): every
// thread must still reach the `omp for`, so wrap per-thread set-up and the loop body in
// separate run() calls; once anything failed, the remaining bodies are skipped, so a body
// never sees a half-built scratch object.
#include <atomic>
#include <exception>
#include <mutex>

namespace lidarflow {

class ParallelErrors {
public:
    // Runs f() unless an earlier call (on any thread) failed; keeps the first exception.
    template <class F>
    void run(F &&f) noexcept {
        if (failed_.load(std::memory_order_relaxed)) return;
        try {
            f();
        } catch (...) {
            keep(std::current_exception());
        }
    }
    bool failed() const noexcept { return failed_.load(std::memory_order_relaxed); }
    // Call after the parallel region, on the thread that opened it.
    void rethrow_if_any() const {
        if (first_) std::rethrow_exception(first_);
    }

private:
    void keep(std::exception_ptr e) noexcept {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!first_) first_ = std::move(e);
        failed_.store(true, std::memory_order_relaxed);
    }

    std::atomic<bool> failed_{false};
    std::mutex mutex_;
    std::exception_ptr first_;
};

}  // namespace lidarflow
