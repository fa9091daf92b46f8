// SPDX-License-Identifier: MIT
#include "motion/ego_motion.hpp"

#include "core/random.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace lidarflow::motion {
namespace {

// Scaled coordinates keep the 4x4 systems well conditioned (pixels ~1000, disparities ~100).
constexpr double kXY = 1e-3, kD = 1e-2;

using Rng = SplitMix64;

// d0 / d1 - 1 as modelled; the divisor is kept away from 0 so a wild model cannot explode.
double depth_ratio(const double a[4], double x, double y, double d0) {
    return std::max(0.2, 1.0 + a[0] + a[1] * x * kXY + a[2] * y * kXY + a[3] * d0 * kD);
}

void depth_row(double x, double y, double d0, double *row) {
    row[0] = 1, row[1] = x * kXY, row[2] = y * kXY, row[3] = d0 * kD;
}

// Row of the x' (k = 0) or y' (k = 1) system; r = d1 / d0 from the depth model.
void flow_row(double x, double y, double r, double d1, int k, double *row) {
    row[0] = 1 - r, row[1] = r, row[2] = r * (k == 0 ? y : x) * kXY, row[3] = d1 * kD;
}

bool solve(const std::vector<double> &rows, const std::vector<double> &rhs, double *out) {
    const int n = static_cast<int>(rhs.size());
    if (n < 4) return false;
    cv::Mat A(n, 4, CV_64F, const_cast<double *>(rows.data()));
    cv::Mat b(n, 1, CV_64F, const_cast<double *>(rhs.data()));
    cv::Mat sol;
    if (!cv::solve(A, b, sol, n == 4 ? cv::DECOMP_LU : cv::DECOMP_QR)) return false;
    for (int i = 0; i < 4; ++i) {
        out[i] = sol.at<double>(i);
        if (!std::isfinite(out[i])) return false;
    }
    return true;
}

struct Data {
    std::vector<int> ids;  // usable matches
    const std::vector<float> &x, &y, &d0, &d1, &u, &v;
};

}  // namespace

bool EgoMotion::predict(float x, float y, float d0, float &d1_out, float &u_out, float &v_out) const {
    if (!valid) {
        d1_out = d0, u_out = 0, v_out = 0;
        return true;
    }
    if (calibrated) return detail::predict_rigid(*this, x, y, d0, d1_out, u_out, v_out);
    const double r = 1.0 / depth_ratio(a, x, y, d0);
    const double d1 = r * d0;
    double rx[4], ry[4];
    flow_row(x, y, r, d1, 0, rx);
    flow_row(x, y, r, d1, 1, ry);
    double xp = r * x, yp = r * y;
    for (int i = 0; i < 4; ++i) xp += bx[i] * rx[i], yp += by[i] * ry[i];
    d1_out = static_cast<float>(d1);
    u_out = static_cast<float>(xp - x);
    v_out = static_cast<float>(yp - y);
    return true;
}

void EgoMotion::predict_many(const float *x, const float *y, const float *d0, int n, float *d1, float *u,
                             float *v) const {
    if (valid && calibrated) {
        detail::predict_rigid_many(*this, x, y, d0, n, d1, u, v);
        return;
    }
    for (int i = 0; i < n; ++i) predict(x[i], y[i], d0[i], d1[i], u[i], v[i]);
}

EgoMotion fit_ego_motion(const std::vector<float> &x, const std::vector<float> &y, const std::vector<float> &d0,
                         const std::vector<float> &d1, const std::vector<float> &u, const std::vector<float> &v,
                         const EgoMotionOptions &o) {
    EgoMotion em;
    Data data{{}, x, y, d0, d1, u, v};
    for (int i = 0; i < static_cast<int>(x.size()); ++i)
        if (d0[i] > 0.5f && d1[i] > 0.5f) data.ids.push_back(i);
    const int n = static_cast<int>(data.ids.size());
    em.candidates = n;
    if (n < std::max(o.min_inliers, 8)) return em;
    // Hypotheses are scored on a fixed, evenly strided subset (bounded cost per frame).
    std::vector<int> probe;
    const int stride = std::max(1, n / 3000);
    for (int k = 0; k < n; k += stride) probe.push_back(data.ids[k]);
    Rng rng(0xE60ull ^ (static_cast<uint64_t>(o.seed) << 17));

    auto d1_err = [&](const double *a, int i) {
        return std::fabs(d0[i] / depth_ratio(a, x[i], y[i], d0[i]) - d1[i]);
    };
    std::vector<double> rows, rhs;
    double row[4];
    // Stage 1: the depth change. d0 / d1 - 1 = q is solved as d0 - d1 = d1 q: the residual is
    // then in pixels of d1, so distant points (where q is noise-dominated) do not dominate.
    auto add_depth = [&](int i) {
        depth_row(x[i], y[i], d0[i], row);
        for (double &r : row) r *= d1[i];
        rows.insert(rows.end(), row, row + 4);
        rhs.push_back(d0[i] - d1[i]);
    };
    double best_a[4] = {0, 0, 0, 0};
    int best_count = -1;
    for (int h = 0; h < o.hypotheses; ++h) {
        rows.clear(), rhs.clear();
        for (int k = 0; k < 4; ++k) {
            const int i = probe[rng.below(static_cast<int>(probe.size()))];
            add_depth(i);
        }
        double a[4];
        if (!solve(rows, rhs, a)) continue;
        int count = 0;
        for (int i : probe) count += d1_err(a, i) < o.disparity_inlier;
        if (count > best_count) best_count = count, std::copy(a, a + 4, best_a);
    }
    if (best_count < 4) return em;
    for (int round = 0; round < 2; ++round) {  // least squares on the inliers of all matches
        rows.clear(), rhs.clear();
        for (int i : data.ids)
            if (d1_err(best_a, i) < o.disparity_inlier) {
                add_depth(i);
            }
        double a[4];
        if (!solve(rows, rhs, a)) break;
        std::copy(a, a + 4, best_a);
    }
    std::copy(best_a, best_a + 4, em.a);

    // Stage 2: the flow, on the depth inliers, with r and d1 from the depth model (a
    // match's own d1 / d0 is far too noisy for distant points).
    std::vector<int> cand;
    std::vector<double> rr(x.size(), 1.0);
    for (int i : data.ids)
        if (d1_err(em.a, i) < o.disparity_inlier) {
            cand.push_back(i);
            rr[i] = 1.0 / depth_ratio(em.a, x[i], y[i], d0[i]);
        }
    if (static_cast<int>(cand.size()) < std::max(o.min_inliers, 8)) return em;
    auto flow_err = [&](const double *bx, const double *by, int i) {
        double rx[4], ry[4];
        const double r = rr[i], dd1 = r * d0[i];
        flow_row(x[i], y[i], r, dd1, 0, rx);
        flow_row(x[i], y[i], r, dd1, 1, ry);
        double xp = r * x[i], yp = r * y[i];
        for (int k = 0; k < 4; ++k) xp += bx[k] * rx[k], yp += by[k] * ry[k];
        return std::hypot(xp - x[i] - u[i], yp - y[i] - v[i]);
    };
    std::vector<int> cprobe;
    const int cstride = std::max(1, static_cast<int>(cand.size()) / 3000);
    for (size_t k = 0; k < cand.size(); k += cstride) cprobe.push_back(cand[k]);
    std::vector<double> rows_y, rhs_y;
    auto add_flow = [&](int i) {
        const double r = rr[i], dd1 = r * d0[i];
        flow_row(x[i], y[i], r, dd1, 0, row);
        rows.insert(rows.end(), row, row + 4);
        rhs.push_back(x[i] + u[i] - r * x[i]);
        flow_row(x[i], y[i], r, dd1, 1, row);
        rows_y.insert(rows_y.end(), row, row + 4);
        rhs_y.push_back(y[i] + v[i] - r * y[i]);
    };
    double best_bx[4] = {0, 0, 0, 0}, best_by[4] = {0, 0, 0, 0};
    best_count = -1;
    for (int h = 0; h < o.hypotheses; ++h) {
        rows.clear(), rhs.clear(), rows_y.clear(), rhs_y.clear();
        for (int k = 0; k < 4; ++k) add_flow(cprobe[rng.below(static_cast<int>(cprobe.size()))]);
        double bx[4], by[4];
        if (!solve(rows, rhs, bx) || !solve(rows_y, rhs_y, by)) continue;
        int count = 0;
        for (int i : cprobe) count += flow_err(bx, by, i) < o.flow_inlier;
        if (count > best_count) {
            best_count = count;
            std::copy(bx, bx + 4, best_bx);
            std::copy(by, by + 4, best_by);
        }
    }
    if (best_count < 4) return em;
    for (int round = 0; round < 2; ++round) {
        rows.clear(), rhs.clear(), rows_y.clear(), rhs_y.clear();
        for (int i : cand)
            if (flow_err(best_bx, best_by, i) < o.flow_inlier) add_flow(i);
        double bx[4], by[4];
        if (!solve(rows, rhs, bx) || !solve(rows_y, rhs_y, by)) break;
        std::copy(bx, bx + 4, best_bx);
        std::copy(by, by + 4, best_by);
    }
    std::copy(best_bx, best_bx + 4, em.bx);
    std::copy(best_by, best_by + 4, em.by);

    // Stage 3: joint refinement. The forward translation shows in d1 - d0 only by fractions
    // of a pixel on the distant points that most matches sit on (a small matcher bias flips
    // its sign), but in the flow it is the expansion about the focus of expansion, many pixels
    // at the image sides. So re-estimate the depth model from the d1 AND the flow residuals,
    // then the flow model given it, alternating. With r = 1 / (1 + q), r - 1 = -q r exactly:
    //   u - B - bx3 d1 = -q r (x - bx0 + B),  B = bx1 + bx2 y   (likewise v), d0 - d1 = d1 q,
    // linear in the depth model a once r is taken from the previous round.
    for (int round = 0; round < o.joint_rounds; ++round) {
        rows.clear(), rhs.clear();
        for (int i : data.ids) {
            const double r = 1.0 / depth_ratio(em.a, x[i], y[i], d0[i]), dd1 = r * d0[i];
            if (std::fabs(dd1 - d1[i]) >= 2 * o.disparity_inlier) continue;
            double fx[4], fy[4];
            flow_row(x[i], y[i], r, dd1, 0, fx);
            flow_row(x[i], y[i], r, dd1, 1, fy);
            double xp = r * x[i], yp = r * y[i];
            for (int k = 0; k < 4; ++k) xp += em.bx[k] * fx[k], yp += em.by[k] * fy[k];
            if (std::hypot(xp - x[i] - u[i], yp - y[i] - v[i]) >= 2 * o.flow_inlier) continue;
            double q[4];
            depth_row(x[i], y[i], d0[i], q);
            const double bxx = em.bx[1] + em.bx[2] * y[i] * kXY, byy = em.by[1] + em.by[2] * x[i] * kXY;
            const double cu = -r * (x[i] - em.bx[0] + bxx), cv = -r * (y[i] - em.by[0] + byy);
            for (int k = 0; k < 4; ++k) row[k] = q[k] * d1[i];
            rows.insert(rows.end(), row, row + 4);
            rhs.push_back(d0[i] - d1[i]);
            for (int k = 0; k < 4; ++k) row[k] = q[k] * cu;
            rows.insert(rows.end(), row, row + 4);
            rhs.push_back(u[i] - bxx - em.bx[3] * dd1 * kD);
            for (int k = 0; k < 4; ++k) row[k] = q[k] * cv;
            rows.insert(rows.end(), row, row + 4);
            rhs.push_back(v[i] - byy - em.by[3] * dd1 * kD);
        }
        double a[4];
        if (!solve(rows, rhs, a)) break;
        std::copy(a, a + 4, em.a);
        // The flow model given the new depth model, on the matches both now explain.
        cand.clear();
        for (int i : data.ids) {
            rr[i] = 1.0 / depth_ratio(em.a, x[i], y[i], d0[i]);
            if (std::fabs(rr[i] * d0[i] - d1[i]) < 2 * o.disparity_inlier && flow_err(em.bx, em.by, i) < 2 * o.flow_inlier)
                cand.push_back(i);
        }
        rows.clear(), rhs.clear(), rows_y.clear(), rhs_y.clear();
        for (int i : cand) add_flow(i);
        double bx[4], by[4];
        if (!solve(rows, rhs, bx) || !solve(rows_y, rhs_y, by)) break;
        std::copy(bx, bx + 4, em.bx);
        std::copy(by, by + 4, em.by);
    }
    cand.clear();
    for (int i : data.ids) {
        rr[i] = 1.0 / depth_ratio(em.a, x[i], y[i], d0[i]);
        if (std::fabs(rr[i] * d0[i] - d1[i]) < o.disparity_inlier) cand.push_back(i);
    }
    for (int i : cand) em.inliers += flow_err(em.bx, em.by, i) < o.flow_inlier;
    em.valid = em.inliers >= std::max(o.min_inliers, static_cast<int>(std::ceil(o.min_inlier_share * n)));
    return em;
}

}  // namespace lidarflow::motion
