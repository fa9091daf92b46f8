// SPDX-License-Identifier: MIT
#pragma once
// Test helper: recomputes a published scene flow with the C ABI from the very input messages
// the bridge used, and compares the planes exactly. Shared by the in-process suite and the
// log checker.
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "bridge_core.hpp"
#include "wire.hpp"

namespace lidarflow::bridge::testing {

// Raw input messages, keyed by utime; calibration is the one in force for the frames.
// bot_core.images_t / pointcloud_t inputs are read here with lcm-gen's generated decoder (not
// the bridge's walkers), the points moved by `lidar_to_camera` (the bridge's --lidar-to-camera).
struct Inputs {
    std::map<int64_t, std::vector<uint8_t>> stereo;  // raw stereo_t or bot_core.images_t
    std::map<int64_t, std::vector<uint8_t>> lidar;   // raw lidar_t or bot_core.pointcloud_t
    bool have_lidar_to_camera = false;
    double lidar_to_camera[16] = {};
};

// The utime of a raw bot_core.images_t / pointcloud_t (lcm-gen's decoder); false when it does
// not decode.
bool bot_core_utime(const std::vector<uint8_t> &raw, int64_t *utime);

// Runs an estimator (options, calibration) on the two frames and LiDAR sweeps `flow` names (a
// fresh one, or the previous call's when its t1 frame is this flow's t0 frame, as the bridge's
// stream continues), encodes the result as `flow` is encoded, and compares every plane value and the valid
// plane. Returns "" when equal, else what differs.
std::string check_flow(const std::vector<std::pair<std::string, std::string>> &options, const lf_calibration_t &cal,
                       const Inputs &inputs, const std::vector<uint8_t> &flow_bytes);

}  // namespace lidarflow::bridge::testing
