// SPDX-License-Identifier: MIT
#pragma once
// The 3-D reading of one scene-flow pixel, shared by lf_get_points3d and the CLI's point cloud
// so the two can never disagree: Z = fx * B / d, X = (x - cx) Z / fx, Y = (y - cy) Z / fy, with
// (x, y, d0) at t0 and (x + u, y + v, d1) at t1, both in the left rectified camera frame.
#include <cmath>
#include <limits>

#include "core/camera.hpp"

namespace lidarflow {

struct ScenePoint3 {
    double x = 0, y = 0, z = 0;     // position at t0 [m]
    double dx = 0, dy = 0, dz = 0;  // position at t1 minus position at t0 [m] (includes ego-motion)
};

// The point at pixel (x, y) with disparity d > 0 in the left rectified camera frame [m]:
// Z = fx * B / d, X = (x - cx) Z / fx, Y = (y - cy) Z / fy.
inline void back_project(const StereoCamera &cam, double x, double y, double d, double xyz[3]) {
    xyz[2] = cam.fx * cam.baseline / d;
    xyz[0] = (x - cam.cx) * xyz[2] / cam.fx;
    xyz[1] = (y - cam.cy) * xyz[2] / cam.fy;
}

// False (and *out untouched) unless d0 > 0 and d1 > 0 and every value fits a float: a
// disparity near 0 puts the point at a depth no float holds, and such a point is not valid
// rather than infinite (a cast of the out-of-range double would be undefined). The camera must
// be valid.
inline bool triangulate_scene_flow(const StereoCamera &cam, double x, double y, double u, double v, double d0,
                                   double d1, ScenePoint3 *out) {
    if (!(d0 > 0.0) || !(d1 > 0.0)) return false;
    double p0[3], p1[3];
    back_project(cam, x, y, d0, p0);
    back_project(cam, x + u, y + v, d1, p1);
    const ScenePoint3 q{p0[0], p0[1], p0[2], p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    const double limit = std::numeric_limits<float>::max();
    for (double c : {q.x, q.y, q.z, q.dx, q.dy, q.dz})
        if (!(std::fabs(c) <= limit)) return false;
    *out = q;
    return true;
}

// Object motion: the point's position at t1 minus where the rigid background motion
// (X1 = R X0 + t, R row-major, both in the left camera frame) would have carried it, i.e. the
// scene flow with the camera's own motion taken out; ~0 on the static world [m, t1 frame].
inline void object_motion(const ScenePoint3 &q, const double R[9], const double t[3], double out[3]) {
    const double p[3] = {q.x, q.y, q.z}, p1[3] = {q.x + q.dx, q.y + q.dy, q.z + q.dz};
    for (int i = 0; i < 3; ++i) out[i] = p1[i] - (R[3 * i] * p[0] + R[3 * i + 1] * p[1] + R[3 * i + 2] * p[2] + t[i]);
}

}  // namespace lidarflow
