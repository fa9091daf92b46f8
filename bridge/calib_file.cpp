// SPDX-License-Identifier: MIT
#include "calib_file.hpp"

namespace lidarflow::bridge {

std::string read_calibration(const std::string &spec, lf_calibration_t *out) {
    lf_calibration_t c;
    lf_calibration_init(&c);
    if (lf_read_calibration(spec.c_str(), nullptr, &c) != LF_OK) return lf_last_error(nullptr);
    *out = c;
    return "";
}

}  // namespace lidarflow::bridge
