// SPDX-License-Identifier: MIT
// calibration_t through the bridge's decoder (bridge/wire.cpp). What decodes has finite values,
// fx, fy, baseline > 0 and an image size in range, and survives an encode/decode round trip.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lf_calibration_t cal;
    int32_t w = -1, h = -1;
    if (!lidarflow::bridge::decode_calibration(data, size, &cal, &w, &h).empty()) return 0;
    const double v[5] = {cal.fx, cal.fy, cal.cx, cal.cy, cal.baseline};
    for (double x : v)
        if (!std::isfinite(x)) std::abort();
    if (!(cal.fx > 0 && cal.fy > 0 && cal.baseline > 0) || w < 0 || h < 0 || w > 16384 || h > 16384) std::abort();
    lidarflow_calibration_t m = lidarflow::bridge::calibration_message(cal, 1, w, h);
    std::vector<uint8_t> buf(static_cast<size_t>(lidarflow_calibration_t_encoded_size(&m)));
    if (lidarflow_calibration_t_encode(buf.data(), 0, static_cast<int>(buf.size()), &m) != static_cast<int>(buf.size()))
        std::abort();
    lf_calibration_t again;
    int32_t w2, h2;
    if (!lidarflow::bridge::decode_calibration(buf.data(), buf.size(), &again, &w2, &h2).empty()) std::abort();
    if (again.fx != cal.fx || again.baseline != cal.baseline || again.cy != cal.cy || w2 != w || h2 != h) std::abort();
    return 0;
}
