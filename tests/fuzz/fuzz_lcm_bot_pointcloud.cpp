// SPDX-License-Identifier: MIT
// bot_core.pointcloud_t through the bridge's decoder (bridge/wire.cpp) with a rigid transform,
// as lidarflow-lcm-bridge runs it with --lidar-to-camera. A sweep that decodes holds camera
// points, no more than the message can carry, all finite after the transform.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static const double T[16] = {0, -1, 0, 0.06, 0, 0, -1, -0.08, 1, 0, 0, -0.27, 0, 0, 0, 1};
    lidarflow::bridge::LidarSweep s;
    if (!lidarflow::bridge::decode_bot_pointcloud(data, size, T, s).empty()) return 0;
    if (s.kind != LF_LIDAR_POINTS_CAMERA || s.xyz.size() % 3 != 0 || 4 * s.xyz.size() > size) std::abort();
    for (float x : s.xyz)
        if (!std::isfinite(x)) std::abort();
    const lf_lidar_t v = s.view();
    if (v.count != s.xyz.size() / 3 || (v.count > 0 && !v.data)) std::abort();
    // The LiDAR-frame form (as sent, for LF_LIDAR_POINTS_LIDAR) has the same points, all finite.
    if (!s.in_lidar_frame || s.lidar_xyz.size() != s.xyz.size()) std::abort();
    for (float x : s.lidar_xyz)
        if (!std::isfinite(x)) std::abort();
    return 0;
}
