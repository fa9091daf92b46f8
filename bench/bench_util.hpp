// SPDX-License-Identifier: MIT
#pragma once
// Small helpers shared by the benchmark programs (not part of the library).
#include <sys/resource.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace lidarflow::bench {

// Gives the heap's free pages back to the system (glibc keeps them after free()), so that the
// next case's peak RSS does not include what the previous case left in the allocator.
inline void release_free_heap() {
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
}

// Resets the kernel's peak-RSS counter (VmHWM) of this process; false where not permitted,
// in which case peak_rss_mib() reports the process-lifetime peak.
inline bool reset_peak_rss() {
    std::ofstream f("/proc/self/clear_refs");
    f << "5";
    return static_cast<bool>(f);
}

// Peak resident set [MiB] since the last successful reset_peak_rss() (or process start).
inline double peak_rss_mib() {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line))
        if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
    rusage r{};
    getrusage(RUSAGE_SELF, &r);
    return r.ru_maxrss / 1024.0;
}

// Calls on(flag, next) for each argument after the program's name; next() reads the value after
// the flag, or calls usage("missing value after FLAG") (which must not return).
template <class Usage, class On>
void for_each_flag(int argc, char **argv, Usage &&usage, On &&on) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) usage(("missing value after " + a).c_str());
            return argv[++i];
        };
        on(a, next);
    }
}

inline double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Median seconds of `runs` calls of f.
template <class F>
double median_seconds(int runs, F &&f) {
    std::vector<double> t;
    for (int r = 0; r < runs; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return median(t);
}

}  // namespace lidarflow::bench
