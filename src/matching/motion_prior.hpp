// SPDX-License-Identifier: MIT
#pragma once
// A stream's motion prior: what moved in the previous pair is expected to go on moving the same
// way. The object motion of each point (its scene flow with the camera's own motion taken out)
// is carried to the pixel where the point lands at t1, which is the next pair's t0.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "motion/ego_motion.hpp"

namespace lidarflow::matching {

// Object motion [m, t1 camera frame] of every point of `field` (a pair's final result) that
// moved with respect to `ego` (a valid calibrated background motion), written at the t1 pixel the
// point lands on (the nearest point where several do); NaN elsewhere, and on the static world.
// Empty when ego is not valid and calibrated or the camera is unknown.
// With steps > 1 the points go on (steps - 1) more frame steps at constant velocity (ego and
// their own object motion, turned by ego's rotation each step), to the pixels of the pair that
// many frames later.
// On `threads` threads (the same result on any count).
cv::Mat3f carry_object_motion(const SceneFlowField &field, const motion::EgoMotion &ego, const StereoCamera &camera,
                              int steps = 1, int threads = 1);

// `prior` (the background motion's flow at each pixel of the disparity map `d`) with the
// flow of background motion + object motion where `objects` (carry_object_motion of the previous
// pair, at d's pixels) holds one; pixels without a disparity keep the background's flow. The
// object motion is turned by m's rotation: constant velocity in the world.
// `m` must be valid and calibrated.
void add_object_motion(const motion::EgoMotion &m, const DisparityMap &d, const cv::Mat3f &objects, cv::Mat2f &prior,
                       int threads = 1);

// `objects` at t0 carried along `flow` to the t1 pixels they land on, turned into the motion
// t1 -> t0 under the background motion `m` (for the backward direction's prior): the forward
// object motion being m's rotation of it (add_object_motion), the way back's is its negative.
cv::Mat3f reverse_object_motion(const cv::Mat3f &objects, const cv::Mat2f &flow, const motion::EgoMotion &m,
                                int threads = 1);

// LiDAR points of earlier frames, at the pixels of the images a stream's next pair starts from.
struct CarriedLidar {
    SparseLidar points;
    std::vector<uint8_t> age;  // per point: how many frames ago it was measured (>= 1)
    bool empty() const { return points.points.empty(); }
};

// The static points among `points` (a pair's t0 points; `age` per point, 0 = measured with this
// pair) moved by the background motion `ego` to the t1 pixels they land on (the nearest of
// several on one pixel), each a frame older; points older than max_age stay behind. A point is
// static when `field` (the pair's final result) moves it as `ego` does from the point's own
// disparity, within 1 px of flow and of d1: movers and points the result does not explain are
// left out. Empty when ego is not valid and calibrated or max_age < 1.
CarriedLidar carry_static_points(const SparseLidar &points, const std::vector<uint8_t> &age,
                                 const SceneFlowField &field, const motion::EgoMotion &ego, int max_age);

// `measured` with the carried points added on pixels no measurement holds, where the stereo
// disparity `d` (of the same images) confirms them within `tolerance` px (a point now hidden,
// or carried wrong, is not); `age` receives 0 for the measured points and the carried ages.
SparseLidar merge_carried(const SparseLidar &measured, const CarriedLidar &carried, const DisparityMap &d,
                          float tolerance, std::vector<uint8_t> &age);

}  // namespace lidarflow::matching
