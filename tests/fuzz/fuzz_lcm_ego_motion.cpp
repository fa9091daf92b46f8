// SPDX-License-Identifier: MIT
// ego_motion_t through the receiver's decoder (bridge/wire.cpp decode_ego_motion, what the
// bridge's tests and consumers use). What decodes has a known state, a finite transform with
// last row 0 0 0 1 (a rotation block when the state is OK, the identity otherwise) and
// 0 <= inliers <= candidates.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lidarflow_ego_motion_t m;
    if (!lidarflow::bridge::decode_ego_motion(data, size, m).empty()) return 0;
    if (m.state < LIDARFLOW_EGO_MOTION_T_STATE_OK || m.state > LIDARFLOW_EGO_MOTION_T_STATE_DISABLED) std::abort();
    for (double v : m.transform)
        if (!std::isfinite(v)) std::abort();
    if (m.transform[12] != 0 || m.transform[13] != 0 || m.transform[14] != 0 || m.transform[15] != 1) std::abort();
    if (m.state == LIDARFLOW_EGO_MOTION_T_STATE_OK) {
        for (int j = 0; j < 3; ++j) {  // unit columns
            const double n = m.transform[j] * m.transform[j] + m.transform[4 + j] * m.transform[4 + j] +
                             m.transform[8 + j] * m.transform[8 + j];
            if (std::fabs(n - 1) > 1e-5) std::abort();
        }
    } else {
        for (int k = 0; k < 16; ++k)
            if (m.transform[k] != (k % 5 == 0 ? 1.0 : 0.0)) std::abort();
    }
    if (m.inliers < 0 || m.inliers > m.candidates) std::abort();
    return 0;
}
