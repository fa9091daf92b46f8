// SPDX-License-Identifier: MIT
#pragma once
// The dominant rigid motion of the scene (in driving: the static background seen from the
// moving camera), fitted robustly to all sparse matches, expressed without calibration.
// For a static point at pixel (x, y) with disparity d0 and a camera motion (small rotation w,
// translation t), a rectified stereo camera gives exactly, to first order in w:
//   d0 / d1        = 1 + a0 + a1 x + a2 y + a3 d0                  (depth change)
//   x' = x + u     = bx0 (1 - r) + r (bx1 + bx2 y) + bx3 d1 + r x   (r = d1 / d0)
//   y' = y + v     = by0 (1 - r) + r (by1 + by2 x) + by3 d1 + r y
// (bx0, by0 play the principal point, a3 / bx3 / by3 the translation, the rest the rotation).
// All three are linear in their unknowns. Two stages use it, so it has its own folder: stage 1's
// decoupled design starts DIS from its flow, and stage 4 subtracts its prediction from the
// matches and interpolates only the remainder: ~0 on the background, so the motion in large
// match-free holes (the road) follows the dense d0 (which LiDAR supports) instead of being
// extrapolated from far-away matches.
// With the camera known (StereoCamera) the model is the rigid motion itself, P' = R P + t on
// the triangulated points: 6 unknowns instead of 12, and no first-order approximation. The
// calibration-free model separates forward translation from rotation poorly where the matches
// lie on distant surfaces (its principal point bx0 / by0 then drifts by hundreds of pixels).
#include <cstdint>
#include <vector>

#include "core/camera.hpp"

namespace lidarflow::motion {

struct EgoMotion {
    bool valid = false;
    // Calibration-free first-order model (calibrated = false).
    double a[4] = {0, 0, 0, 0};
    double bx[4] = {0, 0, 0, 0}, by[4] = {0, 0, 0, 0};
    // Rigid model (calibrated = true): P' = R P + t in the left rectified camera [m], R
    // row-major, for the camera below.
    bool calibrated = false;
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
    StereoCamera camera;
    int inliers = 0;     // matches consistent with the model (d1 and flow)
    int candidates = 0;  // usable matches the fit saw (d0, d1 > 0.5 px for the rigid model)

    // Predicted t1 disparity and flow of a background point at (x, y) with disparity d0 >= 0.
    // Without a valid model: d1 = d0, (u, v) = 0. Returns false when a rigid model moves the
    // point behind the camera (its prediction is then only kept finite).
    bool predict(float x, float y, float d0, float &d1, float &u, float &v) const;
    // predict() of n points (arrays of n; the outputs may not overlap the inputs): the same
    // values as n calls, without the behind-the-camera flag. A rigid model's is vectorised.
    void predict_many(const float *x, const float *y, const float *d0, int n, float *d1, float *u, float *v) const;
    // The motion from t1 back to t0 (R^T, -R^T t), so that predict() maps a t1 pixel and
    // disparity to the t0 ones. Rigid models only; any other gives an invalid model.
    EgoMotion inverse() const;
};

struct EgoMotionOptions {
    int hypotheses = 200;        // RANSAC minimal sets per model (>= 1)
    float disparity_inlier = 1.0f;  // |d1 residual| [px]
    float flow_inlier = 2.0f;       // end-point residual [px]
    float min_inlier_share = 0.3f;  // of the matches, for the model to be used
    int min_inliers = 50;
    int joint_rounds = 4;           // depth/flow alternations after the separate fits (>= 0)
    unsigned seed = 1;
    int threads = 1;  // OpenMP threads of the rigid model's hypothesis scoring; results do not depend on it
};

// Fits the model to matches given as parallel arrays (same length; d0, d1 > 0 where usable:
// others are ignored). Deterministic for a given seed. Returns valid = false when the data do
// not support a dominant motion (too few matches, or too few inliers). Does not throw.
EgoMotion fit_ego_motion(const std::vector<float> &x, const std::vector<float> &y, const std::vector<float> &d0,
                         const std::vector<float> &d1, const std::vector<float> &u, const std::vector<float> &v,
                         const EgoMotionOptions &options);

namespace detail {
// EgoMotion::predict for calibrated models (ego_motion_rigid.cpp).
bool predict_rigid(const EgoMotion &m, float x, float y, float d0, float &d1, float &u, float &v);
void predict_rigid_many(const EgoMotion &m, const float *x, const float *y, const float *d0, int n, float *d1, float *u,
                        float *v);
}  // namespace detail

// The rigid model for a known camera (camera.valid() with finite values required, else
// returns valid = false, as for arrays of differing lengths): RANSAC over 3-point sets, each
// solved by Gauss-Newton on the d1 and flow residuals [px], then refitted on the inliers of
// all matches. Same inputs, inlier rule and determinism as fit_ego_motion; the result has
// calibrated = true. Does not throw.
EgoMotion fit_rigid_ego_motion(const std::vector<float> &x, const std::vector<float> &y, const std::vector<float> &d0,
                               const std::vector<float> &d1, const std::vector<float> &u,
                               const std::vector<float> &v, const EgoMotionOptions &options,
                               const StereoCamera &camera);

}  // namespace lidarflow::motion
