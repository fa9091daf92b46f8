// SPDX-License-Identifier: MIT
// The decoupled stage 1's stereo matcher beside the library it replaces: OpenCV's StereoSGBM
// (3-way, block 5, as stage 2 configures it) and the project's guided SGM, on the KITTI frames
// at a processing scale, image-only and with LiDAR. Prints per matcher and frame: seconds
// (median of --runs), density and D0 outliers (KITTI rule, disp_occ_0, at full resolution) of
// the raw stereo disparity.
//
//   bench_stereo --root DIR [--ids 000002,000003] [--scale 0.55] [--runs 5] [--threads 2]
//                [--lidar paper|velodyne|none] [--beams K] [--placement P]
//                [--p1 N] [--p2 N] [--paths 4|8] [--slope F] [--cap N] [--radius N] [--intensity N]
//                [--ternary] [--census-threshold N]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "args.hpp"
#include "bench_util.hpp"
#include "consistency/sgm_check.hpp"
#include "core/error.hpp"
#include "eval/kitti_runner.hpp"
#include "eval/metrics.hpp"
#include "io/kitti_png.hpp"
#include "pipeline/resolution.hpp"
#include "stereo/guided_sgm.hpp"

using namespace lidarflow;

namespace {

[[noreturn]] void usage(const char *msg) {
    std::fprintf(stderr,
                 "%s\nusage: bench_stereo --root DIR [--ids A,B] [--scale S] [--runs N] [--threads N]\n"
                 "  [--lidar paper|velodyne|none] [--beams K] [--placement P] [--p1 N] [--p2 N] [--paths 4|8]\n"
                 "  [--slope F] [--cap N] [--radius N] [--intensity N] [--ternary] [--census-threshold N]\n",
                 msg);
    std::exit(2);
}

// Density and D0 outliers [%] of a disparity of the scaled frame against the full-resolution
// ground truth (each GT pixel reads the nearest scaled pixel, disparities divided by the scale).
void score(const DisparityMap &d, const DisparityMap &gt, double sx, double sy, double &density, double &outliers) {
    size_t n = 0, have = 0, bad = 0;
    for (int y = 0; y < gt.rows; ++y)
        for (int x = 0; x < gt.cols; ++x) {
            if (!disparity_valid(gt(y, x))) continue;
            ++n;
            const int xs = std::min(d.cols - 1, static_cast<int>(x * sx)),
                      ys = std::min(d.rows - 1, static_cast<int>(y * sy));
            const float e = d(ys, xs);
            if (!disparity_valid(e)) continue;
            ++have;
            if (eval::disparity_outlier(gt(y, x), static_cast<float>(e / sx))) ++bad;
        }
    density = n ? 100.0 * have / n : 0;
    outliers = have ? 100.0 * bad / have : 0;
}

}  // namespace

int main(int argc, char **argv) try {
    std::string root;
    std::vector<std::string> ids{"000002", "000003"};
    double scale = 0.55;
    int runs = 5;
    eval::LidarInputOptions lidar;
    stereo::GuidedSgmOptions g;
    g.threads = 2;
    bench::for_each_flag(argc, argv, usage, [&](const std::string &a, const auto &next) {
        if (a == "--root") root = next();
        else if (a == "--ids") ids = cli::split_list(next());
        else if (a == "--scale") scale = std::atof(next().c_str());
        else if (a == "--runs") runs = std::max(1, std::atoi(next().c_str()));
        else if (a == "--threads") g.threads = std::max(1, std::atoi(next().c_str()));
        else if (a == "--lidar") lidar.protocol = eval::parse_protocol(next());
        else if (a == "--beams") lidar.beams = std::atoi(next().c_str());
        else if (a == "--placement") lidar.placement = std::atoi(next().c_str());
        else if (a == "--p1") g.p1 = std::atoi(next().c_str());
        else if (a == "--p2") g.p2 = std::atoi(next().c_str());
        else if (a == "--paths") g.paths = std::atoi(next().c_str());
        else if (a == "--slope") g.lidar_slope = static_cast<float>(std::atof(next().c_str()));
        else if (a == "--cap") g.lidar_cap = std::atoi(next().c_str());
        else if (a == "--radius") g.lidar_radius = std::atoi(next().c_str());
        else if (a == "--intensity") g.lidar_intensity = std::atoi(next().c_str());
        else if (a == "--ternary") g.ternary_census = true;
        else if (a == "--census-threshold") g.census_threshold = std::atoi(next().c_str());
        else usage(("unknown argument " + a).c_str());
    });
    if (root.empty()) usage("--root is required");
    if (lidar.protocol == eval::LidarProtocol::Velodyne) lidar.points = 0;
    cv::setNumThreads(g.threads);
    std::printf("%-7s %-14s %9s %8s %9s\n", "frame", "matcher", "seconds", "density", "D0 out%");
    for (const std::string &id : ids) {
        const eval::KittiFrame f = eval::load_kitti_frame(root, id, lidar);
        const DisparityMap gt = io::read_disparity_png(root + "/disp_occ_0/" + id + "_10.png");
        const cv::Size size = pipeline::scaled_size(f.input.left0.cols, f.input.left0.rows, scale);
        const pipeline::FrameInput small = pipeline::downscale_frame(f.input, size);
        const double sx = static_cast<double>(size.width) / f.input.left0.cols,
                     sy = static_cast<double>(size.height) / f.input.left0.rows;
        consistency::SgmOptions so;
        so.num_disparities = std::max(16, static_cast<int>(std::ceil(128 * scale / 16)) * 16);
        g.num_disparities = so.num_disparities;
        const SparseLidar none{size.width, size.height, {}};
        struct Case {
            const char *name;
            std::function<DisparityMap()> run;
        };
        const std::vector<Case> cases{
            {"opencv-sgbm", [&] { return consistency::compute_sgm_disparity(small.left0, small.right0, so); }},
            {"guided/image", [&] { return stereo::guided_sgm(small.left0, small.right0, none, g); }},
            {"guided/lidar", [&] { return stereo::guided_sgm(small.left0, small.right0, small.lidar0, g); }},
        };
        for (const Case &c : cases) {
            DisparityMap d;
            const double s = bench::median_seconds(runs, [&] { d = c.run(); });
            double density = 0, out = 0;
            score(d, gt, sx, sy, density, out);
            std::printf("%-7s %-14s %9.4f %7.1f%% %8.2f%%\n", id.c_str(), c.name, s, density, out);
        }
        std::printf("%-7s lidar points: %zu\n", id.c_str(), small.lidar0.points.size());
    }
    return 0;
} catch (const std::exception &e) {
    std::fprintf(stderr, "bench_stereo: %s\n", e.what());
    return 1;
}
