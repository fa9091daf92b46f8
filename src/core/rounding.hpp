// SPDX-License-Identifier: MIT
#pragma once
// std::lround for the float coordinates of per-pixel loops, inline: libm's lroundf is a call
// (it may set errno), which kept those loops scalar.
#include <algorithm>
#include <cmath>

namespace lidarflow {

// The nearest integer to v, half-way values away from zero (as std::lround), for |v| < 2^30;
// larger magnitudes (no pixel's) give +-2^30, NaN 0. In double v +- 0.5 is exact for every
// |v| >= 2^-30 (and rounds below 1 under it), so truncating it rounds as lround does.
inline int round_to_int(float v) {
    constexpr double kLimit = 1073741824.0;  // 2^30
    const double x = std::clamp(static_cast<double>(v) + std::copysign(0.5, static_cast<double>(v)), -kLimit, kLimit);
    return x == x ? static_cast<int>(x) : 0;
}

// (round_to_int(x), round_to_int(y)) into (tx, ty) when that pixel lies inside a w x h image.
inline bool nearest_inside(float x, float y, int w, int h, int &tx, int &ty) {
    tx = round_to_int(x);
    ty = round_to_int(y);
    return tx >= 0 && ty >= 0 && tx < w && ty < h;
}

}  // namespace lidarflow
