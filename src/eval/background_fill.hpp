// SPDX-License-Identifier: MIT
#pragma once
// Hole filling of an estimate before it is scored, with the same result as the official KITTI
// Scene Flow 2015 devkit ("background interpolation", io_disp.h / io_flow.h):
//  1. each row: a run of invalid pixels between two valid ones takes the smaller of the two
//     neighbouring values (the one farther away, i.e. the background); for flow the minimum is
//     taken per component (u and v separately), as the devkit does;
//  2. each row: invalid pixels before the first / after the last valid one copy that value;
//  3. each column: invalid pixels above the first / below the last valid one copy that value.
// Rows without any valid pixel that lie between valid rows stay invalid (the devkit leaves them
// too, and then scores their stored numbers: -1 for disparity, (0, 0) for flow).
#include "core/maps.hpp"

namespace lidarflow::eval {

// Returns a filled copy; the input is not modified. Invalid pixels of the result hold exactly
// kInvalidDisparity. Throws InvalidArgument on an empty map.
DisparityMap fill_background(const DisparityMap &disp);

// Returns a filled copy; invalid pixels of the result hold (0, 0) with valid = 0. Throws
// InvalidArgument on an empty field and SizeMismatch when u, v and valid differ in size.
FlowField fill_background(const FlowField &flow);

}  // namespace lidarflow::eval
