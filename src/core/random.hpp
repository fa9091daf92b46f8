// SPDX-License-Identifier: MIT
#pragma once
// splitmix64: a tiny generator that is statistically fine and gives the same numbers on every
// platform (std:: distributions do not), so seeded stages stay reproducible everywhere.
#include <cstdint>

namespace lidarflow {

struct SplitMix64 {
    uint64_t s;
    explicit SplitMix64(uint64_t seed) : s(seed) {}
    uint64_t next() {
        uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    // Uniform integer in [0, n), n > 0.
    int below(int n) { return static_cast<int>(next() % static_cast<uint64_t>(n)); }
    // Uniform float in [0, 1).
    float uniform() { return static_cast<float>(next() >> 40) * (1.0f / 16777216.0f); }
};

}  // namespace lidarflow
