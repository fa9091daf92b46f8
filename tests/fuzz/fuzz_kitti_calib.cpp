// SPDX-License-Identifier: MIT
// The KITTI calibration parsers (src/io/calib.cpp) on text in memory: calib_cam_to_cam and
// calib_velo_to_cam, both on every input. Each either throws lidarflow::Error or returns what
// its header promises: finite matrices, and a camera inside the ranges of core/limits.hpp
// (checked here against the numbers, not through camera_range_error), so that fx * baseline and
// the depths fx * baseline / d of every accepted disparity are finite.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "io/calib.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string text(reinterpret_cast<const char *>(data), size);
    try {
        const lidarflow::io::CamToCamCalib c = lidarflow::io::parse_calib_cam_to_cam(text, "fuzz");
        for (int i = 0; i < 12; ++i)
            if (!std::isfinite(c.P_rect_02.val[i]) || !std::isfinite(c.P_rect_03.val[i])) std::abort();
        for (int i = 0; i < 9; ++i)
            if (!std::isfinite(c.R_rect_00.val[i])) std::abort();
        using namespace lidarflow;
        const StereoCamera &k = c.camera;
        if (!(k.fx >= kMinFocal && k.fx <= kMaxFocal && k.fy >= kMinFocal && k.fy <= kMaxFocal)) std::abort();
        if (!(std::fabs(k.cx) <= kMaxPrincipalPoint && std::fabs(k.cy) <= kMaxPrincipalPoint)) std::abort();
        if (!(k.baseline >= kMinBaseline && k.baseline <= kMaxBaseline)) std::abort();
        const double fb = k.fx * k.baseline;
        if (!std::isfinite(fb) || !std::isfinite(fb / 0x1p-126)) std::abort();  // depth of the smallest normal d
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
