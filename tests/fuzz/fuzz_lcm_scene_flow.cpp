// SPDX-License-Identifier: MIT
// scene_flow_t through the receiver's decoder (bridge/wire.cpp decode_scene_flow, what the
// bridge's tests and consumers use). What decodes has planes of width x height values, with
// width = ceil(image_width / step), and valid bytes of 0 or 1.
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lidarflow::bridge::DecodedFlow f;
    if (!lidarflow::bridge::decode_scene_flow(data, size, f).empty()) return 0;
    const lidarflow_scene_flow_t &h = f.header;
    if (h.width < 1 || h.height < 1 || h.step < 1 || h.width != (h.image_width + h.step - 1) / h.step ||
        h.height != (h.image_height + h.step - 1) / h.step)
        std::abort();
    const size_t n = static_cast<size_t>(h.width) * static_cast<size_t>(h.height);
    if (f.u.size() != n || f.v.size() != n || f.d0.size() != n || f.d1.size() != n || f.valid.size() != n) std::abort();
    for (uint8_t b : f.valid)
        if (b > 1) std::abort();
    if (h.u || h.v || h.d0 || h.d1 || h.valid) std::abort();
    return 0;
}
