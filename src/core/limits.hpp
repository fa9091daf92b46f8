// SPDX-License-Identifier: MIT
#pragma once
// Accepted ranges of the inputs, shared by every entry point (C ABI, CLI readers, the bridge
// through the C ABI) and checked again by the core, so that no caller reaches a computation
// that overflows. include/lidarflow/lidarflow.h documents the same numbers.
#include <string>

#include "core/camera.hpp"

namespace lidarflow {

// Image side [px]. Keeps byte counts far from overflow and, with the SGM stage's left padding
// (<= 1024 px), images below the 16-bit pixel coordinates of OpenCV's speckle filter.
constexpr int kMaxImageSide = 16384;

// LiDAR disparity [px]: 0 (a point at infinity) up to kMaxLidarDisparity. A larger disparity
// moves the point out of every accepted image and overflows integer pixel arithmetic.
constexpr float kMaxLidarDisparity = 16384.0f;

// Camera: fx, fy in [kMinFocal, kMaxFocal] px; |cx|, |cy| <= kMaxPrincipalPoint px; baseline in
// [kMinBaseline, kMaxBaseline] m. Hence fx * baseline lies in [1e-4, 1e10] px m, and depths
// fx * baseline / d of disparities >= 2^-126 (the smallest normal float) stay finite.
constexpr double kMinFocal = 1.0, kMaxFocal = 1e6;
constexpr double kMaxPrincipalPoint = 1e6;
constexpr double kMinBaseline = 1e-4, kMaxBaseline = 1e4;

// The translation of a LiDAR -> camera transform [m], per axis: a rig is not a kilometre wide, and
// a larger one (a unit slip, 1e30) puts every point behind or far outside the image.
constexpr double kMaxRigTranslation = 1e3;

// "" when the camera lies in the ranges above, else what is wrong ("fx = 1e-300 px is outside
// [1, 1e+06]"). NaN and infinities are outside every range.
std::string camera_range_error(const StereoCamera &camera);

// Whether the camera is the default, all-zero "unknown rig" (calibration-free models).
bool camera_unknown(const StereoCamera &camera);

}  // namespace lidarflow
