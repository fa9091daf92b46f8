// SPDX-License-Identifier: MIT
// bot_core.image_t through the bridge's walker (bridge/wire.cpp, what lidarflow-lcm-bridge runs
// on every image of --left-channel / --right-channel). An image it accepts pairs with itself
// into a stereo frame of a format the C ABI takes, in-range dimensions and packed rows, whose
// pixels lie inside the decoder's own buffer (read here in full, so ASan sees any overrun).
#include <cstdint>
#include <cstdlib>

#include "fuzz_bot_frame.hpp"
#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    int64_t utime = 0;
    if (!lidarflow::bridge::check_bot_image(data, size, &utime).empty()) return 0;
    lidarflow::bridge::StereoMessage m;
    // Accepted alone but refused as a pair: only for dimensions out of range or short rows.
    if (!lidarflow::bridge::decode_bot_image_pair(data, size, data, size, m).empty()) return 0;
    if (m.msg().utime != utime) std::abort();
    lidarflow::fuzz::check_bot_frame(m);
    return 0;
}
