// SPDX-License-Identifier: MIT
#pragma once
// How the estimator shares the machine with other processes (docs/ARCHITECTURE.md, "Threads").

#include <functional>

namespace lidarflow {

// The default "threads" of the library, the CLI, Python and the bridge: the CPUs this process
// may run on (its affinity mask), in [1, 256]. With adaptive threads (threads_for_now) a frame
// still takes only the CPUs other processes leave idle. Thread-safe; never throws.
int default_threads();

// How many of `requested` OpenMP threads a frame should use now: the CPUs this process may run
// on, less the tasks other processes keep runnable (other_runnable_tasks: the kernel's count in
// /proc/loadavg less this process's own runnable threads, read before and after it), at least 1
// and at most `requested`; a count that would take threads away is read again 2 ms later
// (threads_from_samples), so a process busy for a moment does not halve a frame. A team larger
// than the idle CPUs makes every barrier wait for a descheduled thread, so a shared machine ran
// 2 threads slower than 1. Results never depend on it (every stage is deterministic for any
// thread count). Without /proc it returns `requested`. Thread-safe; never throws.
int threads_for_now(int requested);

// threads_for_now's rule on given samples: other_tasks() returns the other processes' runnable
// tasks (< 0: unknown, all `requested` threads). When the first sample leaves fewer than
// `requested` of the `cpus` idle, pause() runs and the second sample decides unless the first
// left more threads. Never throws unless the callbacks do.
int threads_from_samples(int requested, int cpus, const std::function<int()> &other_tasks,
                         const std::function<void()> &pause);

// The tasks of other processes among `running` (the kernel's count of runnable tasks, the caller
// included), when this process had own_before and own_after runnable threads just before and
// just after that count was read: the larger of the two is this process's share (at least the
// caller). Never negative.
int other_runnable_tasks(int running, int own_before, int own_after);

// Ends the calling thread's OpenMP worker pool when it is outside any parallel region, so that
// its idle workers sleep (they exit) instead of spin-waiting for the next region (libgomp spins
// for milliseconds by default, taking the CPUs from OpenCV's own threads and from other
// processes). The next parallel region starts a new pool. With LLVM's libomp (clang builds),
// whose pause is process-wide, it does nothing. Thread-safe; never throws.
void release_openmp_workers();

// The first of n items in part `part` of `parts` near-equal consecutive parts (part == parts:
// n), for splitting rows or columns into one band per thread. Never throws.
inline int band_start(int n, int part, int parts) {
    return static_cast<int>(static_cast<long long>(n) * part / parts);
}

// f(part, begin, end) for each of `parts` bands of n items (band_start), in a parallel region of
// `parts` threads (fewer when the runtime gives fewer). f must not throw (use ParallelErrors).
template <class F>
void for_each_band(int n, int parts, F &&f) {
#pragma omp parallel for num_threads(parts) schedule(static, 1)
    for (int part = 0; part < parts; ++part) f(part, band_start(n, part, parts), band_start(n, part + 1, parts));
}

}  // namespace lidarflow
