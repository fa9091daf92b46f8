// SPDX-License-Identifier: MIT
#pragma once
// Shared by the bot_core image targets: what every stereo frame made from bot_core images must
// be, whichever message it came from.
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

namespace lidarflow::fuzz {

// Aborts unless the frame has a format the C ABI takes, dimensions in range, packed rows and no
// frame number; reads both images in full, so that ASan sees a pixel outside the frame's buffer.
inline void check_bot_frame(const lidarflow::bridge::StereoMessage &m) {
    const lidarflow_stereo_t &s = m.msg();
    const int bpp = s.pixel_format == LF_PIXEL_GRAY8 ? 1 : 3;
    if (s.pixel_format < LF_PIXEL_GRAY8 || s.pixel_format > LF_PIXEL_BGR8) std::abort();
    if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384) std::abort();
    if (s.row_stride != s.width * bpp || s.size != s.row_stride * s.height || m.has_frame_number()) std::abort();
    volatile unsigned sum = 0;
    for (const lf_image_t &im : {m.left(), m.right()}) {
        const auto *p = static_cast<const uint8_t *>(im.data);
        for (int32_t i = 0; i < s.size; ++i) sum = sum + p[i];
    }
}

}  // namespace lidarflow::fuzz
