// SPDX-License-Identifier: MIT
// lidarflow synth: renders synthetic stereo + LiDAR frames with exact ground truth and writes
// them in the KITTI Scene Flow 2015 layout (plus lidar_0/1 and masks/).
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

int run_synth(int argc, char **argv) {
    Args args("synth", argc, argv,
              {{"out", true, "DIR  output folder (KITTI layout; created)"},
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
