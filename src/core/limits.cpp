// SPDX-License-Identifier: MIT
#include "core/limits.hpp"

#include <cmath>
#include <sstream>

namespace lidarflow {
namespace {

// The negated comparison makes NaN fail too.
std::string outside(const char *name, double v, double lo, double hi, const char *unit) {
    if (v >= lo && v <= hi) return "";
    std::ostringstream s;
    s << name << " = " << v << ' ' << unit << " is outside [" << lo << ", " << hi << "]";
    return s.str();
}

}  // namespace

std::string camera_range_error(const StereoCamera &c) {
    for (std::string e : {outside("fx", c.fx, kMinFocal, kMaxFocal, "px"), outside("fy", c.fy, kMinFocal, kMaxFocal, "px"),
                          outside("cx", c.cx, -kMaxPrincipalPoint, kMaxPrincipalPoint, "px"),
                          outside("cy", c.cy, -kMaxPrincipalPoint, kMaxPrincipalPoint, "px"),
                          outside("baseline", c.baseline, kMinBaseline, kMaxBaseline, "m")})
        if (!e.empty()) return e;
    return "";
}

bool camera_unknown(const StereoCamera &c) {
    return c.fx == 0 && c.fy == 0 && c.cx == 0 && c.cy == 0 && c.baseline == 0;
}

}  // namespace lidarflow
