// SPDX-License-Identifier: MIT
#pragma once
// The heap policy of lidarflow's own programs (the CLI, lidarflow-lcm-bridge, the benchmarks).
//
// Why: a frame allocates and frees many whole-image buffers (fields, edge maps, clusters).
// glibc serves blocks above its mmap threshold (at most 32 MiB, adjusted at run time) from fresh
// mappings and trims the top of its heaps past the trim threshold, so every frame faults in and
// zeroes ~50-100 MB of pages again; on the KVM/PVM machines measured that was a third of the
// `bench_pipeline` system time and ~15 % of a streamed frame (docs/experiments/speed-stage1.md).
// Keeping freed memory in the process reuses those pages for the next frame, at the price of
// ~40-50 MiB more resident memory. The library itself never changes the allocator of the
// process that embeds it: an application chooses, e.g. with the same values in GLIBC_TUNABLES.
#include <cstdlib>
#include <cstring>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lidarflow::tools {

struct HeapPolicy {
    bool applied = false;  // false: not glibc, or the user's GLIBC_TUNABLES set malloc already
    const char *describe() const {
        return applied ? "keep (mmap threshold 32 MiB, trim threshold 256 MiB)" : "glibc defaults";
    }
};

// Call once at the start of main(), before any thread starts. A GLIBC_TUNABLES that sets any
// malloc tunable wins: the program then leaves the allocator as the user configured it.
inline HeapPolicy apply_heap_policy() {
    HeapPolicy p;
#if defined(__GLIBC__)
    const char *env = std::getenv("GLIBC_TUNABLES");
    if (env && std::strstr(env, "glibc.malloc.")) return p;
    // 32 MiB is the largest threshold glibc accepts on 64-bit (HEAP_MAX_SIZE / 2); the
    // descriptor images above it are mapped by the library itself (huge_page_allocator.hpp).
    const int mmap_ok = mallopt(M_MMAP_THRESHOLD, 32 << 20);
    const int trim_ok = mallopt(M_TRIM_THRESHOLD, 256 << 20);
    p.applied = mmap_ok == 1 && trim_ok == 1;
#endif
    return p;
}

}  // namespace lidarflow::tools
