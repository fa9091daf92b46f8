// SPDX-License-Identifier: MIT
#include "interpolation/piecewise_model.hpp"

#include <algorithm>

namespace lidarflow::interp {

bool plane_from_3(const float x[3], const float y[3], const float z[3], Plane &out) {
    const double x1 = x[1] - x[0], y1 = y[1] - y[0], x2 = x[2] - x[0], y2 = y[2] - y[0];
    const double det = x1 * y2 - x2 * y1;  // twice the triangle's signed area
    const double l01 = x1 * x1 + y1 * y1, l02 = x2 * x2 + y2 * y2;
    const double l12 = (x2 - x1) * (x2 - x1) + (y2 - y1) * (y2 - y1);
    const double longest = std::max({l01, l02, l12});
    // Slivers extrapolate wildly across the superpixel: demand a height of >= 5% of the
    // longest side and at least ~1.5 px^2 of area.
    if (std::fabs(det) < std::max(3.0, 0.05 * longest)) return false;
    const double z1 = z[1] - z[0], z2 = z[2] - z[0];
    const double a = (z1 * y2 - z2 * y1) / det;
    const double b = (x1 * z2 - x2 * z1) / det;
    out.a = static_cast<float>(a);
    out.b = static_cast<float>(b);
    out.c = static_cast<float>(z[0] - a * x[0] - b * y[0]);
    return true;
}

void PlaneLsq::add(float x, float y, float w, const float *z, int dims) {
    const double dx = x - ox_, dy = y - oy_;
    sxx_ += w * dx * dx;
    sxy_ += w * dx * dy;
    syy_ += w * dy * dy;
    sx_ += w * dx;
    sy_ += w * dy;
    s1_ += w;
    for (int k = 0; k < dims; ++k) {
        sxz_[k] += w * dx * z[k];
        syz_[k] += w * dy * z[k];
        sz_[k] += w * z[k];
    }
}

bool PlaneLsq::solve(int dims, Model &out) const {
    if (s1_ <= 0) return false;
    // Centre on the weighted mean: the 2x2 slope system then decouples from the offset.
    const double mx = sx_ / s1_, my = sy_ / s1_;
    const double cxx = sxx_ / s1_ - mx * mx, cxy = sxy_ / s1_ - mx * my, cyy = syy_ / s1_ - my * my;
    const double det = cxx * cyy - cxy * cxy;
    const double tr = cxx + cyy;
    // Points spread along a line (or a single point) leave one slope undetermined.
    if (!(tr > 0.25) || det < 0.01 * tr * tr) return false;
    for (int k = 0; k < dims; ++k) {
        const double mz = sz_[k] / s1_;
        const double cxz = sxz_[k] / s1_ - mx * mz, cyz = syz_[k] / s1_ - my * mz;
        const double a = (cxz * cyy - cyz * cxy) / det;
        const double b = (cyz * cxx - cxz * cxy) / det;
        const double c0 = mz - a * mx - b * my;  // value at the origin (ox, oy)
        out.p[k].a = static_cast<float>(a);
        out.p[k].b = static_cast<float>(b);
        out.p[k].c = static_cast<float>(c0 - a * ox_ - b * oy_);
    }
    return true;
}

}  // namespace lidarflow::interp
