// SPDX-License-Identifier: MIT
#pragma once
// The rig options of the commands that take one's own images: --calib FILE[,FILE] or --fx --fy
// --cx --cy --baseline, and --strict (io/rig.hpp reads the files).
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "args.hpp"
#include "io/rig.hpp"

namespace lidarflow::cli {

// The OptionSpec entries of the rig options, for a command's Args spec.
std::vector<OptionSpec> rig_option_specs();

// The rig the options give, or none. Throws Error(InvalidArgument) for --calib together with
// the numbers, or numbers without --fx / --cx / --cy / --baseline (--fy defaults to --fx);
// whatever io::read_rig throws for the files.
std::optional<io::Rig> rig_from_args(const Args &args, const std::string &command);

// For a command whose inputs carry their own calibration: throws Error(InvalidArgument)
// "COMMAND takes no --calib: WHY" when argv (from argv[1]) names a rig option, so that the user
// learns why rather than meeting an unknown option.
void refuse_rig_options(int argc, char **argv, const std::string &command, const std::string &why);

// The images' size against the rig's (io::image_size_mismatch): nothing when they agree or the
// rig's is unknown; otherwise `strict` throws Error(SizeMismatch), else a warning goes to stderr.
void check_image_size(const io::Rig &rig, cv::Size images, bool strict, const std::string &command);

}  // namespace lidarflow::cli
