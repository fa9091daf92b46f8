// SPDX-License-Identifier: MIT
#include "synth_args.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>

#include "core/error.hpp"

namespace lidarflow::cli {

synth::SynthConfig synth_config_from_args(const Args &args, const std::string &command) {
    synth::SynthConfig c;
    const int seed = args.integer("seed", 1);
    require(seed >= 0, ErrorCode::InvalidArgument, command + ": --seed must be >= 0");
    c.seed = static_cast<uint64_t>(seed);
    c.width = args.integer("width", c.width);
    c.height = args.integer("height", c.height);
    c.lidar_points = args.integer("points", c.lidar_points);
    c.noise_sigma = args.number("noise", c.noise_sigma);
    c.lidar_noise = args.number("lidar-noise", c.lidar_noise);
    return c;
}

int parse_frame_id(const std::string &id, const std::string &command) {
    require(id.size() == 6 && std::all_of(id.begin(), id.end(), [](unsigned char ch) { return std::isdigit(ch); }),
            ErrorCode::InvalidArgument, command + ": --id must be 6 digits (e.g. 000000), got '" + id + "'");
    return std::stoi(id);
}

std::string format_frame_id(int n) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%06d", n);
    return buf;
}

}  // namespace lidarflow::cli
