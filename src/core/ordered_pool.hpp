// SPDX-License-Identifier: MIT
#pragma once
// Frames in flight: jobs run on a few persistent threads and come back in the order they were
// submitted (docs/ARCHITECTURE.md, "Frames in flight").
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include "core/error.hpp"

namespace lidarflow {

// At most capacity() jobs in flight, each on its own persistent thread, so a job starts when it
// is submitted. An owner that takes the oldest as soon as the pool is full keeps capacity() - 1
// jobs running between its calls, and capacity() while it waits. Persistent threads keep their
// heap arenas from job to job. One thread at a time submits and takes (the
// owner); the jobs run concurrently with the owner and with each other. A job that throws hands
// the exception to take_oldest().
template <class T>
class OrderedPool {
public:
    // Throws Error(InvalidArgument) unless 1 <= workers <= 64; std::system_error when a thread
    // cannot be started.
    explicit OrderedPool(int workers) {
        require(workers >= 1 && workers <= 64, ErrorCode::InvalidArgument,
                "frames in flight must be in [1, 64], not " + std::to_string(workers));
        capacity_ = static_cast<size_t>(workers);
        try {
            for (int i = 0; i < workers; ++i) threads_.emplace_back([this] { work(); });
        } catch (...) {
            stop();
            throw;
        }
    }
    // Waits for every job in flight (their results are dropped).
    ~OrderedPool() {
        drain();
        stop();
    }
    OrderedPool(const OrderedPool &) = delete;
    OrderedPool &operator=(const OrderedPool &) = delete;

    size_t capacity() const { return capacity_; }
    size_t in_flight() const { return results_.size(); }
    bool full() const { return results_.size() >= capacity_; }

    // Starts `job` on an idle thread. Throws Error(BadState) when full(): take_oldest() first.
    // On any throw (std::bad_alloc too) nothing was submitted.
    void submit(std::function<T()> job) {
        require(!full(), ErrorCode::BadState, "every frame worker is busy");
        std::packaged_task<T()> task(std::move(job));
        std::future<T> result = task.get_future();
        results_.push_back(std::move(result));
        try {
            const std::lock_guard<std::mutex> lock(mutex_);
            queue_.push_back(std::move(task));
        } catch (...) {
            results_.pop_back();  // the job never runs: it must not count as in flight
            throw;
        }
        wake_.notify_one();
    }

    // The oldest job's future (get() waits for it and rethrows what it threw). Throws
    // Error(BadState) when nothing is in flight.
    std::future<T> take_oldest() {
        require(!results_.empty(), ErrorCode::BadState, "no frame in flight");
        std::future<T> f = std::move(results_.front());
        results_.pop_front();
        return f;
    }

    // Waits for every job in flight and drops their results and errors.
    void drain() noexcept {
        for (std::future<T> &f : results_) f.wait();
        results_.clear();
    }

private:
    void work() {
        for (;;) {
            std::packaged_task<T()> task;
            {
                std::unique_lock<std::mutex> lock(mutex_);
                wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
                if (queue_.empty()) return;  // stopping, nothing left
                task = std::move(queue_.front());
                queue_.pop_front();
            }
            task();  // stores the value or the exception in the job's future
        }
    }
    void stop() noexcept {
        {
            const std::lock_guard<std::mutex> lock(mutex_);
            stopping_ = true;
        }
        wake_.notify_all();
        for (std::thread &t : threads_) t.join();
        threads_.clear();
    }

    size_t capacity_ = 1;
    std::deque<std::future<T>> results_;  // owner's side, oldest first
    std::mutex mutex_;
    std::condition_variable wake_;
    std::deque<std::packaged_task<T()>> queue_;  // jobs not yet picked up by a thread
    bool stopping_ = false;
    std::vector<std::thread> threads_;
};

}  // namespace lidarflow
