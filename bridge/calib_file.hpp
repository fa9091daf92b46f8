// SPDX-License-Identifier: MIT
#pragma once
// The bridge's --calib: any calibration source lf_read_calibration reads (KITTI
// calib_cam_to_cam.txt, an OpenCV stereo calibration file, "LEFT,RIGHT" camera_info YAMLs;
// docs/CALIBRATION.md), through the C ABI as everything the bridge does.
#include <string>

#include "lidarflow/lidarflow.h"

namespace lidarflow::bridge {

// Reads `spec` into *out (camera, image size, and the raw cameras of a rig the estimator must
// rectify). Returns "" or the problem, naming the file (unreadable, not a regular file, too
// large, malformed, a key missing or repeated, not a stereo pair).
std::string read_calibration(const std::string &spec, lf_calibration_t *out);

}  // namespace lidarflow::bridge
