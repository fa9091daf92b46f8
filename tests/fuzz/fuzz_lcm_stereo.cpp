// SPDX-License-Identifier: MIT
// stereo_t through the bridge's decoder (bridge/wire.cpp, what lidarflow-lcm-bridge runs on every
// message of its stereo channel). A message that decodes must describe two images that lie
// inside it: every byte of both is read, so ASan sees any overrun.
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lidarflow::bridge::StereoMessage m;
    if (!lidarflow::bridge::decode_stereo(data, size, m).empty()) return 0;
    const lf_image_t l = m.left(), r = m.right();
    const unsigned bpp = l.format == LF_PIXEL_GRAY8 ? 1 : 3;
    if (l.width < 1 || l.height < 1 || l.stride_bytes < l.width * bpp || !l.data || !r.data) std::abort();
    unsigned sum = 0;
    for (uint64_t i = 0; i < l.stride_bytes * l.height; ++i)
        sum += static_cast<const uint8_t *>(l.data)[i] ^ static_cast<const uint8_t *>(r.data)[i];
    return static_cast<int>(sum & 0);
}
