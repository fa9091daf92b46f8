// SPDX-License-Identifier: MIT
#pragma once
// Options shared by the commands that render synthetic scenes (synth, demo).
#include <string>

#include "args.hpp"
#include "synth/scene.hpp"

namespace lidarflow::cli {

// SynthConfig from --seed --width --height --points --noise --lidar-noise where the command
// declares them (absent options keep the defaults). Throws Error(InvalidArgument) for a
// negative seed or malformed numbers; render() checks the ranges of the rest.
synth::SynthConfig synth_config_from_args(const Args &args, const std::string &command);

// "000042" -> 42. Throws Error(InvalidArgument) unless the id is exactly 6 digits.
int parse_frame_id(const std::string &id, const std::string &command);
// 42 -> "000042".
std::string format_frame_id(int n);

}  // namespace lidarflow::cli
