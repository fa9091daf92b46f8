// SPDX-License-Identifier: MIT
#include "core/threads.hpp"

#include <dirent.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>

#include <omp.h>

#include "core/regular_file.hpp"

namespace lidarflow {
namespace {

int usable_cpus() {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof(set), &set) != 0) return 0;
    return CPU_COUNT(&set);
}

// Runnable tasks in the whole system now, the caller included (0 when unknown).
int runnable_tasks() {
    // Opened as a regular file with a bound: a FIFO or device bound over it must not stall frames.
    RegularFile f("/proc/loadavg");
    std::string text;
    if (!f.read_all(text, 4096)) return 0;
    double l1, l5, l15;
    int running = 0, total = 0;
    const bool ok = std::sscanf(text.c_str(), "%lf %lf %lf %d/%d", &l1, &l5, &l15, &running, &total) == 5;
    return ok ? running : 0;
}

// Runnable threads of this process now (its idle OpenCV or OpenMP workers may still be spinning:
// they are not another process's load). 0 when unknown.
int own_runnable_threads() {
    DIR *dir = opendir("/proc/self/task");
    if (!dir) return 0;
    int running = 0;
    char path[64], buf[512];
    while (const dirent *e = readdir(dir)) {
        if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
        std::snprintf(path, sizeof(path), "/proc/self/task/%.20s/stat", e->d_name);
        RegularFile f(path);
        if (!f.ok()) continue;
        const ssize_t got = ::read(f.fd(), buf, sizeof(buf) - 1);
        const size_t n = got > 0 ? static_cast<size_t>(got) : 0;
        buf[n] = '\0';
        // "pid (comm) S ...": the state follows the last ')' (comm may hold one).
        const char *close = std::strrchr(buf, ')');
        if (close && close[1] == ' ' && close[2] == 'R') ++running;
    }
    closedir(dir);
    return running;
}

}  // namespace

int default_threads() {
    int cpus = usable_cpus();
    if (cpus <= 0) cpus = static_cast<int>(std::thread::hardware_concurrency());
    return std::clamp(cpus, 1, 256);  // 256: the "threads" key's upper bound
}

int other_runnable_tasks(int running, int own_before, int own_after) {
    return std::max(0, running - std::max({1, own_before, own_after}));  // the caller is one of ours
}

int threads_from_samples(int requested, int cpus, const std::function<int()> &other_tasks,
                         const std::function<void()> &pause) {
    if (requested <= 1) return std::max(1, requested);
    if (cpus <= 0) return requested;
    auto idle = [&] {
        const int others = other_tasks();
        return others < 0 ? requested : std::clamp(cpus - others, 1, requested);
    };
    const int first = idle();
    if (first >= requested) return first;
    pause();
    return std::max(first, idle());
}

int threads_for_now(int requested) {
    // Our idle workers spin a while and then sleep: one read of our threads could miss one that
    // the kernel's count caught running and take it for another process. A thread counts as ours
    // when it runs at either read around the kernel's count.
    const auto other_tasks = [] {
        const int before = own_runnable_threads();
        const int running = runnable_tasks();
        return running <= 0 ? -1 : other_runnable_tasks(running, before, own_runnable_threads());
    };
    // A process that hands over the frame (a camera driver, the LCM publisher) is often still
    // running when the frame starts; 2 ms later it has gone back to sleep.
    return threads_from_samples(requested, usable_cpus(), other_tasks,
                                [] { std::this_thread::sleep_for(std::chrono::milliseconds(2)); });
}

void release_openmp_workers() {
#if defined(__clang__)
    // Clang builds use LLVM's libomp, whose pause stops the whole process's runtime, other host
    // threads' teams included: not ours to do. Its workers sleep after KMP_BLOCKTIME instead.
#else
    // libgomp (GCC): the pause ends only the calling thread's pool.
    if (omp_in_parallel() || omp_get_level() > 0) return;
    omp_pause_resource(omp_pause_soft, omp_get_initial_device());
#endif
}

}  // namespace lidarflow
