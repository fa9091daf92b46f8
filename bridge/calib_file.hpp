// SPDX-License-Identifier: MIT
#pragma once
// The bridge's --calib file: a KITTI calib_cam_to_cam.txt (P_rect_02 and P_rect_03 lines; the
// other keys are ignored). The bridge uses only the C ABI, so it reads the file itself.
#include <string>

#include "lidarflow/lidarflow.h"

namespace lidarflow::bridge {

// Reads `path` into *out (fx = P2(0,0), fy = P2(1,1), cx = P2(0,2), cy = P2(1,2), baseline =
// (P2(0,3) - P3(0,3)) / fx, as lidarflow's KITTI reader). Returns "" or the problem (file
// unreadable, a key missing or repeated, not 12 finite numbers, fx / fy / baseline <= 0).
std::string read_kitti_calibration(const std::string &path, lf_calibration_t *out);

}  // namespace lidarflow::bridge
