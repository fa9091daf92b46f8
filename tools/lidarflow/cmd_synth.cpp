// SPDX-License-Identifier: MIT
// lidarflow synth: renders synthetic stereo + LiDAR frames with exact ground truth and writes
// them in the KITTI Scene Flow 2015 layout (plus lidar_0/1 and masks/); with --drive, one
// continuous drive in the KITTI raw layout (images, Velodyne scans, calibration, ground truth).
#include <chrono>
#include <cstdio>
#include <string>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "synth/scene.hpp"
#include "synth_args.hpp"
#include "synth/write_kitti.hpp"

namespace lidarflow::cli {
namespace {

// A continuous drive of `frames` frames (synth/scene.hpp), layout in synth/write_kitti.hpp.
int write_drive(const Args &args) {
    const std::string root = args.required("drive");
    // An empty path would put the drive's folders into the working directory's root ("/gt").
    require(!root.empty(), ErrorCode::InvalidArgument, "synth: --drive must not be empty");
    for (const char *other : {"out", "id", "points", "lidar-noise"})
        require(!args.has(other), ErrorCode::InvalidArgument,
                std::string("synth: --") + other + " does not apply to --drive (a drive has Velodyne scans, frame "
                "indices from 0 and the folder --drive)");
    const synth::SynthConfig config = synth_config_from_args(args, "synth");
    require(args.has("frames"), ErrorCode::InvalidArgument, "synth: --drive needs --frames N (2 to " +
                                                               std::to_string(synth::kMaxDriveFrames) + ")");
    const int frames = args.integer("frames", 0);
    require(frames >= 2 && frames <= synth::kMaxDriveFrames, ErrorCode::InvalidArgument,
            "synth: --frames must be in [2, " + std::to_string(synth::kMaxDriveFrames) +
                "] with --drive (further on, the camera would reach the car ahead)");
    synth::write_drive_rig(config, root);
    synth::write_drive_timestamps(root, frames);
    synth::write_drive_poses(config, root, frames);
    for (int k = 0; k < frames; ++k) {
        const auto t0 = std::chrono::steady_clock::now();
        const synth::DriveFrame frame = synth::render_drive_frame(config, k);
        synth::write_drive_frame(frame, root, k);
        if (k + 1 < frames) synth::write_drive_ground_truth(synth::render_drive_ground_truth(config, k), root, k);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        std::printf("%s  %dx%d  scan %zu points  rendered in %.0f ms\n", synth::drive_frame_name(k).c_str(),
                    config.width, config.height, frame.scan.size(), ms);
    }
    std::printf("wrote a drive of %d frames (seed %llu) to %s, ground truth of its %d pairs in %s/gt\n", frames,
                static_cast<unsigned long long>(config.seed), root.c_str(), frames - 1, root.c_str());
    return 0;
}

int run_synth(int argc, char **argv) {
    Args args("synth", argc, argv,
              {{"out", true, "DIR  output folder (KITTI layout; created)"},
               {"drive", true, "DIR  instead: one continuous drive in the KITTI raw layout (image_02, image_03, velodyne_points, calib_*.txt, gt/), --frames 2.." + std::to_string(synth::kMaxDriveFrames)},
               {"id", true, "NNNNNN  id of the first frame (default 000000)"},
               {"frames", true, "K  number of frames, ids id..id+K-1, seeds seed..seed+K-1 (default 1)"},
               {"seed", true, "S  scene seed (default 1)"},
               {"width", true, "W  image width (default 640)"},
               {"height", true, "H  image height (default 192)"},
               {"points", true, "N  LiDAR points per frame (default 88)"},
               {"noise", true, "SIGMA  image noise, grey levels (default 1)"},
               {"lidar-noise", true, "SIGMA  LiDAR disparity noise, px (default 0)"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    if (args.has("drive")) return write_drive(args);
    const std::string out = args.required("out");
    synth::SynthConfig config = synth_config_from_args(args, "synth");
    const int frames = args.integer("frames", 1);
    require(frames >= 1 && frames <= 100000, ErrorCode::InvalidArgument, "synth: --frames must be in [1, 100000]");
    const int first = parse_frame_id(args.str("id", "000000"), "synth");
    require(first + static_cast<long>(frames) - 1 <= 999999, ErrorCode::InvalidArgument,
            "synth: frame ids would exceed 999999");
    const uint64_t seed = config.seed;
    for (int k = 0; k < frames; ++k) {
        config.seed = seed + static_cast<uint64_t>(k);
        const std::string id = format_frame_id(first + k);
        const auto t0 = std::chrono::steady_clock::now();
        const synth::SynthScene scene = synth::render(config);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        synth::write_kitti(scene, out, id);
        std::printf("%s  seed %llu  %dx%d  LiDAR %zu + %zu points  rendered in %.0f ms\n", id.c_str(),
                    static_cast<unsigned long long>(config.seed), config.width, config.height,
                    scene.lidar0.points.size(), scene.lidar1.points.size(), ms);
    }
    std::printf("wrote %d frame(s) to %s\n", frames, out.c_str());
    return 0;
}

}  // namespace
}  // namespace lidarflow::cli

LIDARFLOW_COMMAND(synth, "synth", "render synthetic stereo + LiDAR frames with exact ground truth (KITTI layout)",
                  lidarflow::cli::run_synth, 20);
