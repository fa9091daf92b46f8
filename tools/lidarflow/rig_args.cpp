// SPDX-License-Identifier: MIT
#include "rig_args.hpp"

#include <cstdio>

#include "core/error.hpp"

namespace lidarflow::cli {

std::vector<OptionSpec> rig_option_specs() {
    return {{"calib", true,
             "FILE[,FILE] the rig: KITTI calib_cam_to_cam.txt, an OpenCV stereo calibration (YAML/XML), or "
             "LEFT,RIGHT ROS camera_info YAMLs (docs/CALIBRATION.md); raw rigs are rectified"},
            {"fx", true, "PX   rectified rig by numbers (instead of --calib): focal length"},
            {"fy", true, "PX   vertical focal length (default: --fx)"},
            {"cx", true, "PX   principal point column"},
            {"cy", true, "PX   principal point row"},
            {"baseline", true, "M    distance of the left and right camera centres"},
            {"strict", false, "refuse images of another size than the calibration's (default: a warning)"}};
}

std::optional<io::Rig> rig_from_args(const Args &args, const std::string &command) {
    const bool numbers = args.has("fx") || args.has("fy") || args.has("cx") || args.has("cy") || args.has("baseline");
    require(!(numbers && args.has("calib")), ErrorCode::InvalidArgument,
            command + ": give --calib or --fx/--cx/--cy/--baseline, not both");
    if (args.has("calib")) return io::read_rig(args.str("calib", ""));
    if (!numbers) return std::nullopt;
    require(args.has("fx") && args.has("cx") && args.has("cy") && args.has("baseline"), ErrorCode::InvalidArgument,
            command + ": a rig by numbers needs --fx, --cx, --cy and --baseline (--fy defaults to --fx)");
    StereoCamera cam;
    cam.fx = args.number("fx", 0);
    cam.fy = args.number("fy", cam.fx);
    cam.cx = args.number("cx", 0);
    cam.cy = args.number("cy", 0);
    cam.baseline = args.number("baseline", 0);
    return io::rig_from_pinhole(cam);
}

void refuse_rig_options(int argc, char **argv, const std::string &command, const std::string &why) {
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        for (const OptionSpec &o : rig_option_specs()) {
            const std::string name = "--" + o.name;
            if (o.takes_value && (arg == name || arg.rfind(name + "=", 0) == 0))
                throw Error(ErrorCode::InvalidArgument, command + " takes no " + name + ": " + why);
        }
    }
}

void check_image_size(const io::Rig &rig, cv::Size images, bool strict, const std::string &command) {
    const std::string mismatch = io::image_size_mismatch(rig.rect.image_size, images);
    if (mismatch.empty()) return;
    require(!strict, ErrorCode::SizeMismatch, command + ": " + mismatch + " (--strict)");
    std::fprintf(stderr, "lidarflow %s: warning: %s; the calibration is used as it is (--strict refuses)\n",
                 command.c_str(), mismatch.c_str());
}

}  // namespace lidarflow::cli
