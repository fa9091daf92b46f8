// SPDX-License-Identifier: MIT
#pragma once
// LIDARFLOW_AVX2_CLONES: compiles a function for AVX2 and for the baseline ISA; the loader picks
// one (GCC function multiversioning). For plain loops the compiler vectorises: AVX2 without FMA
// performs the same IEEE operations per element, so both versions give the same results.
// Not on function templates (clang 14 clones none): a cloned function inlines the template.
// Only on functions of internal linkage: clang 14 gives a clone set's dispatcher another symbol
// than the one other translation units call, so an entry point used elsewhere is a plain
// function that calls the clones.
// The pick runs in an IFUNC resolver during relocation, before a ThreadSanitizer runtime is
// up, and crashes there: TSan builds keep only the baseline version.
#if defined(__SANITIZE_THREAD__)
#define LIDARFLOW_AVX2_CLONES
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define LIDARFLOW_AVX2_CLONES
#endif
#endif
#ifndef LIDARFLOW_AVX2_CLONES
#define LIDARFLOW_AVX2_CLONES __attribute__((target_clones("avx2", "default")))
#endif

// LIDARFLOW_V3_CLONES: as above for integer kernels that also need the POPCNT instruction
// (GCC's "avx2" clone calls a library routine for __builtin_popcountll; x86-64-v3 is AVX2 +
// POPCNT + FMA, picked by CPU features, where an "arch=haswell" clone is picked by CPU model).
// Integer only: that clone may contract float expressions into FMA, changing float results.
#if defined(__SANITIZE_THREAD__)
#define LIDARFLOW_V3_CLONES
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define LIDARFLOW_V3_CLONES
#endif
#endif
#ifndef LIDARFLOW_V3_CLONES
#define LIDARFLOW_V3_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#endif

namespace lidarflow {

// Whether the CPU runs AVX2: the pick between a kernel written with its intrinsics (in a
// target("avx2") function) and the portable loop beside it; false off x86. Thread-safe (asked
// once).
inline bool cpu_has_avx2() {
#if defined(__x86_64__) || defined(__i386__)
    static const bool yes = __builtin_cpu_supports("avx2");
    return yes;
#else
    return false;
#endif
}

}  // namespace lidarflow
