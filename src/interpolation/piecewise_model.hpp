// SPDX-License-Identifier: MIT
#pragma once
// Affine models over image coordinates, the per-superpixel pieces of the interpolation:
// a plane d = a x + b y + c for a disparity (exact for a planar surface in a rectified
// camera), and a pair of them for the flow (u, v) (the affine approximation of the
// homography a moving plane induces). Plain value types; no allocation.
#include <cmath>

namespace lidarflow::interpolation {

struct Plane {
    float a = 0, b = 0, c = 0;
    float at(float x, float y) const { return a * x + b * y + c; }
};

// One piecewise model of one channel; dims == 1 (a disparity) or 2 (flow u, v).
struct Model {
    Plane p[2];
};

// Plane through three points (x_i, y_i, z_i). Returns false for a degenerate (near-collinear)
// triple: doubled triangle area below max(min_area2, sliver * longest side^2).
bool plane_from_3(const float x[3], const float y[3], const float z[3], Plane &out);

// Accumulates a weighted least-squares plane fit; solve() returns false when the weighted
// points do not span a plane (fewer than three or near-collinear).
class PlaneLsq {
public:
    // Coordinates relative to (ox, oy) keep the normal equations well conditioned.
    PlaneLsq(float ox, float oy) : ox_(ox), oy_(oy) {}
    // Inline: stage 4's refinement adds every inlier of every candidate.
    void add(float x, float y, float w, const float *z, int dims) {
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
    bool solve(int dims, Model &out) const;

private:
    float ox_, oy_;
    double sxx_ = 0, sxy_ = 0, syy_ = 0, sx_ = 0, sy_ = 0, s1_ = 0;
    double sxz_[2] = {0, 0}, syz_[2] = {0, 0}, sz_[2] = {0, 0};
};

// Stage 4's hot loop: the robust cost of a model over a superpixel's neighbours, as eight lane
// sums (one running sum would be a chain the compiler may not reorder). Over the points
// j < n (n a multiple of 8), lane j mod 8 adds, in order of j, w_j * min(tau, r_j) where r_j is
// |p0(x_j, y_j) - z0_j| for dims 1, the norm of (p0 - z0, p1 - z1) at j for dims 2 (z1 unread
// for dims 1). Every instruction set computes the same operations per lane, so all give the
// same sums, NaN included (a NaN residual adds min(tau, NaN) = NaN).
enum class LaneIsa { Best, Portable, Sse2, Avx2 };
void robust_lanes(const Model &m, int dims, const float *x, const float *y, const float *z0, const float *z1,
                  const float *w, int n, float tau, float acc[8], LaneIsa isa = LaneIsa::Best);
// Whether robust_lanes can run isa here (Portable always; Best is whichever is fastest).
bool lane_isa_available(LaneIsa isa);

}  // namespace lidarflow::interpolation
