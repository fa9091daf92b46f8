// SPDX-License-Identifier: MIT
#pragma once
// A stream's motion prior: what moved in the previous pair is expected to go on moving the same
// way. The object motion of each point (its scene flow with the camera's own motion taken out)
// is carried to the pixel where the point lands at t1, which is the next pair's t0.
#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/maps.hpp"
#include "motion/ego_motion.hpp"

namespace lidarflow::matching {

// Object motion [m, t1 camera frame] of every point of `field` (a pair's final result) that
// moved with respect to `ego` (a valid calibrated background motion), written at the t1 pixel the
// point lands on (the nearest point where several do); NaN elsewhere, and on the static world.
// Empty when ego is not valid and calibrated or the camera is unknown.
cv::Mat3f carry_object_motion(const SceneFlowField &field, const motion::EgoMotion &ego, const StereoCamera &camera);

// `prior` (the background motion's flow at each pixel of the disparity map `d`) with the
// flow of background motion + object motion where `objects` (carry_object_motion of the previous
// pair, at d's pixels) holds one; pixels without a disparity keep the background's flow.
// `m` must be valid and calibrated.
void add_object_motion(const motion::EgoMotion &m, const DisparityMap &d, const cv::Mat3f &objects, cv::Mat2f &prior);

// `objects` at t0 carried along `flow` to the t1 pixels they land on, turned into the motion
// t1 -> t0 under the background motion `m` (for the backward direction's prior).
cv::Mat3f reverse_object_motion(const cv::Mat3f &objects, const cv::Mat2f &flow, const motion::EgoMotion &m);

}  // namespace lidarflow::matching
