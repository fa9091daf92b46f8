// SPDX-License-Identifier: MIT
// bot_core.image_t through the bridge's walker (bridge/wire.cpp, what lidarflow-lcm-bridge runs
// on every image of --left-channel / --right-channel). An image it accepts pairs with itself
// into a stereo frame of a format the C ABI takes, in-range dimensions and packed rows, whose
// pixels lie inside the decoder's own buffer (read here in full, so ASan sees any overrun).
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    int64_t utime = 0;
    if (!lidarflow::bridge::check_bot_image(data, size, &utime).empty()) return 0;
    lidarflow::bridge::StereoMessage m;
    // Accepted alone but refused as a pair: only for dimensions out of range or short rows.
    if (!lidarflow::bridge::decode_bot_image_pair(data, size, data, size, m).empty()) return 0;
    const lidarflow_stereo_t &s = m.msg();
    const int bpp = s.pixel_format == LF_PIXEL_GRAY8 ? 1 : 3;
    if (s.utime != utime || s.pixel_format < LF_PIXEL_GRAY8 || s.pixel_format > LF_PIXEL_BGR8) std::abort();
    if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384) std::abort();
    if (s.row_stride != s.width * bpp || s.size != s.row_stride * s.height || m.has_frame_number()) std::abort();
    unsigned sum = 0;
    for (const lf_image_t &im : {m.left(), m.right()}) {
        const auto *p = static_cast<const uint8_t *>(im.data);
        for (int32_t i = 0; i < s.size; ++i) sum += p[i];
    }
    return static_cast<int>(sum & 0);
}
