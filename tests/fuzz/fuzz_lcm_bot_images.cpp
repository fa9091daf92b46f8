// SPDX-License-Identifier: MIT
// bot_core.images_t through the bridge's decoder (bridge/wire.cpp, what lidarflow-lcm-bridge
// runs on every images_t of its stereo channel). A pair that decodes has a format the C ABI
// takes, dimensions in range, packed rows, and both images lie inside the decoder's own buffer
// (read here in full, so ASan sees any overrun).
#include <cstdint>

#include "fuzz_bot_frame.hpp"
#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lidarflow::bridge::StereoMessage m;
    if (!lidarflow::bridge::decode_bot_images(data, size, m).empty()) return 0;
    lidarflow::fuzz::check_bot_frame(m);
    return 0;
}
