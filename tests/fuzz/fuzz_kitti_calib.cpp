// SPDX-License-Identifier: MIT
// The KITTI calibration parsers (src/io/calib.cpp) on text in memory: calib_cam_to_cam and
// calib_velo_to_cam, both on every input. Each either throws lidarflow::Error or returns what
// its header promises.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/error.hpp"
#include "io/calib.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string text(reinterpret_cast<const char *>(data), size);
    try {
        const lidarflow::io::CamToCamCalib c = lidarflow::io::parse_calib_cam_to_cam(text, "fuzz");
        for (int i = 0; i < 12; ++i)
            if (!std::isfinite(c.P_rect_02.val[i]) || !std::isfinite(c.P_rect_03.val[i])) std::abort();
        if (!(c.camera.fx > 0 && c.camera.fy > 0 && c.camera.baseline > 0)) std::abort();
    } catch (const lidarflow::Error &) {
    }
    try {
        const cv::Matx44d M = lidarflow::io::parse_calib_velo_to_cam(text, "fuzz");
        for (int i = 0; i < 16; ++i)
            if (!std::isfinite(M.val[i])) std::abort();
        if (M(3, 0) != 0 || M(3, 1) != 0 || M(3, 2) != 0 || M(3, 3) != 1) std::abort();
    } catch (const lidarflow::Error &) {
    }
    return 0;
}
