// SPDX-License-Identifier: MIT
#include "core/threads.hpp"

#include <sched.h>

#include <algorithm>
#include <cstdio>

#include <omp.h>

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
    std::FILE *f = std::fopen("/proc/loadavg", "r");
    if (!f) return 0;
    double l1, l5, l15;
    int running = 0, total = 0;
    const bool ok = std::fscanf(f, "%lf %lf %lf %d/%d", &l1, &l5, &l15, &running, &total) == 5;
    std::fclose(f);
    return ok ? running : 0;
}

}  // namespace

int threads_for_now(int requested) {
    if (requested <= 1) return std::max(1, requested);
    const int cpus = usable_cpus(), running = runnable_tasks();
    if (cpus <= 0 || running <= 0) return requested;
    const int others = running - 1;  // the caller is one of them
    return std::clamp(cpus - others, 1, requested);
}

void release_openmp_workers() {
    if (omp_in_parallel() || omp_get_level() > 0) return;
    omp_pause_resource(omp_pause_soft, omp_get_initial_device());
}

}  // namespace lidarflow
