// SPDX-License-Identifier: MIT
#include "calib_file.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

namespace lidarflow::bridge {

std::string read_kitti_calibration(const std::string &path, lf_calibration_t *out) {
    std::ifstream in(path);
    if (!in) return path + ": cannot open";
    std::vector<double> P2, P3;
    std::string line;
    while (std::getline(in, line)) {
        const size_t colon = line.find(':');
        if (colon == std::string::npos) continue;
        const std::string key = line.substr(0, colon);
        std::vector<double> *dst = key == "P_rect_02" ? &P2 : key == "P_rect_03" ? &P3 : nullptr;
        if (!dst) continue;
        if (!dst->empty()) return path + ": " + key + " appears twice";
        std::istringstream values(line.substr(colon + 1));
        std::string tok;
        while (values >> tok) {
            char *end = nullptr;
            const double v = std::strtod(tok.c_str(), &end);
            if (end == tok.c_str() || *end != '\0' || !std::isfinite(v))
                return path + ": " + key + " has a bad value '" + tok + "'";
            dst->push_back(v);
        }
        if (dst->size() != 12)
            return path + ": " + key + " has " + std::to_string(dst->size()) + " values, expected 12";
    }
    if (P2.empty()) return path + ": no P_rect_02 (not a KITTI calib_cam_to_cam file?)";
    if (P3.empty()) return path + ": no P_rect_03";
    lf_calibration_init(out);
    out->fx = P2[0];
    out->fy = P2[5];
    out->cx = P2[2];
    out->cy = P2[6];
    if (!(out->fx > 0 && out->fy > 0)) return path + ": P_rect_02 has a non-positive focal length";
    out->baseline = (P2[3] - P3[3]) / out->fx;
    if (!(out->baseline > 0)) return path + ": P_rect_02 / P_rect_03 give a non-positive baseline";
    return "";
}

}  // namespace lidarflow::bridge
