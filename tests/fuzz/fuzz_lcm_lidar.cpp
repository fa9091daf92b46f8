// SPDX-License-Identifier: MIT
// lidar_t through the bridge's decoder (bridge/wire.cpp, what lidarflow-lcm-bridge runs on every
// message of its LiDAR channel). A sweep that decodes is of a kind the C ABI takes, has as many
// entries as the message declares, and every value is finite (also after lidar_to_camera).
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lidarflow::bridge::LidarSweep s;
    if (!lidarflow::bridge::decode_lidar(data, size, s).empty()) return 0;
    if (s.kind != LF_LIDAR_POINTS_CAMERA && s.kind != LF_LIDAR_DISPARITY) std::abort();
    if (s.xyz.size() % 3 != 0 || 8 + 141 + 4 * s.xyz.size() != size) std::abort();
    for (float x : s.xyz)
        if (!std::isfinite(x)) std::abort();
    const lf_lidar_t v = s.view();
    if (v.count != s.xyz.size() / 3 || (v.count > 0 && !v.data)) std::abort();
    // The LiDAR-frame form (as sent, for LF_LIDAR_POINTS_LIDAR) has the same points, all finite.
    if (s.in_lidar_frame ? s.lidar_xyz.size() != s.xyz.size() : !s.lidar_xyz.empty()) std::abort();
    for (float x : s.lidar_xyz)
        if (!std::isfinite(x)) std::abort();
    const lf_lidar_t w = s.lidar_frame_view();
    if (w.kind != LF_LIDAR_POINTS_LIDAR || w.count != s.lidar_xyz.size() / 3) std::abort();
    return 0;
}
