// SPDX-License-Identifier: MIT
#pragma once
// Counter-based randomness for the synthetic renderer. Every value is a pure function of
// (key, coordinates), so rendering can run in any order on any number of threads and still be
// bit-identical for a seed. Internal to src/synth.
#include <cmath>
#include <cstdint>

namespace lidarflow::synth {

// SplitMix64 finaliser: a bijective 64-bit mix with good avalanche.
inline uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

// One finaliser over a linear combination: enough decorrelation for lattice noise, at half the
// cost of nesting (this is the renderer's inner loop).
inline uint64_t hash2(uint64_t key, int64_t a, int64_t b) {
    return mix64(key + static_cast<uint64_t>(a) * 0x632be59bd9b4e019ULL + static_cast<uint64_t>(b) * 0x8cb92ba72f3d8dd7ULL);
}

// Uniform in [0, 1) from the top 53 bits.
inline double unit(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

// Standard normal sample for counter `index` under `key` (Box-Muller on two hashed uniforms).
inline double gaussian(uint64_t key, uint64_t index) {
    const uint64_t h = mix64(key ^ mix64(index));
    const double u1 = unit(h) + 0x1.0p-54;  // never 0: log(0) would be -inf
    const double u2 = unit(mix64(h));
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
}

// Sequential generator for scene layout decisions (not used per pixel).
class LayoutRng {
public:
    explicit LayoutRng(uint64_t seed) : state_(mix64(seed ^ 0x5851f42d4c957f2dULL)) {}
    double uniform(double lo, double hi) { return lo + (hi - lo) * unit(next()); }
    uint64_t next() { return mix64(state_++); }

private:
    uint64_t state_;
};

// Smooth value noise in [-1, 1] on the integer lattice, quintic interpolation (C2).
inline double value_noise(double x, double y, uint64_t key) {
    const double fx = std::floor(x), fy = std::floor(y);
    const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
    const double tx = x - fx, ty = y - fy;
    const double sx = tx * tx * tx * (tx * (tx * 6 - 15) + 10);
    const double sy = ty * ty * ty * (ty * (ty * 6 - 15) + 10);
    // hash2 at the four corners, sharing the linear part.
    const uint64_t kx = 0x632be59bd9b4e019ULL, ky = 0x8cb92ba72f3d8dd7ULL;
    const uint64_t base = key + static_cast<uint64_t>(ix) * kx + static_cast<uint64_t>(iy) * ky;
    const double a = unit(mix64(base)), b = unit(mix64(base + kx));
    const double c = unit(mix64(base + ky)), d = unit(mix64(base + kx + ky));
    const double top = a + (b - a) * sx, bottom = c + (d - c) * sx;
    return 2.0 * (top + (bottom - top) * sy) - 1.0;
}

// Weight of a pattern of wavelength `lambda` [m] when one sample covers `footprint` [m]:
// 1 when it is resolved (>= 4 samples per period), 0 when it would alias (< 2), linear between.
// Fading unresolvable detail to its mean is what area sampling would converge to.
inline double band_weight(double lambda, double footprint) {
    const double r = lambda / footprint;
    return r >= 4.0 ? 1.0 : (r <= 2.0 ? 0.0 : 0.5 * (r - 2.0));
}

// Band-limited fractal sum of value noise, roughly in [-1, 1]. Octave i has wavelength
// lambda_max / 2^i and amplitude gain^i; each octave is rotated to hide the lattice axes.
// Dividing by the full amplitude sum (not the surviving one) makes far surfaces lose contrast.
inline double fbm(double x, double y, uint64_t key, double lambda_max, int octaves, double gain,
                  double footprint) {
    // Octave i is rotated by i times the golden angle (2.39996 rad).
    static const double kCos[8] = {1.000000000, -0.737368723, 0.087425267, 0.608439408,
                                   -0.984713645, 0.843754678, -0.259602974, -0.460908452};
    static const double kSin[8] = {0.000000000, 0.675490464, -0.996171081, 0.793600332,
                                   -0.174181046, -0.536729022, 0.965715432, -0.887447688};
    double sum = 0, norm = 0, amp = 1, lambda = lambda_max;
    for (int i = 0; i < octaves; ++i, amp *= gain, lambda *= 0.5) {
        norm += amp;
        const double w = band_weight(lambda, footprint);
        if (w <= 0) continue;
        const double c = kCos[i & 7], s = kSin[i & 7];
        sum += amp * w * value_noise((c * x - s * y) / lambda, (s * x + c * y) / lambda, key + 0x9e37ULL * (i + 1));
    }
    return norm > 0 ? sum / norm : 0.0;
}

}  // namespace lidarflow::synth
