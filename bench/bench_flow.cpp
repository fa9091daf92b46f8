// SPDX-License-Identifier: MIT
// The decoupled stage 1's flow search as it runs: OpenCV's DISOpticalFlow at a preset's settings
// on the reduced KITTI frames (gray, both directions as the matcher searches them), and how its
// time splits: the full search, the same with one descent step and no spatial propagation (what
// every call pays whatever the steps: pyramids, gradients, the patches' sums, densification),
// and the steps' share (the difference). A flow search of the project's own could only win back
// what it does better than OpenCV's in each part; this says how large the parts are.
//
//   bench_flow --root DIR [--ids 000002,000003] [--preset realtime|fast|default] [--runs 9]
//              [--threads 2]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/video.hpp>

#include "args.hpp"
#include "bench_util.hpp"
#include "core/gray.hpp"
#include "eval/kitti_runner.hpp"
#include "matching/decoupled_matcher.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/resolution.hpp"

using namespace lidarflow;

namespace {

[[noreturn]] void usage(const char *msg) {
    std::fprintf(stderr,
                 "%s\nusage: bench_flow --root DIR [--ids A,B] [--preset realtime|fast|default] [--runs N] "
                 "[--threads N]\n",
                 msg);
    std::exit(2);
}

// Median seconds of both directions (from -> to with o, then to -> from with o.backward()), each
// a fresh DIS as the matcher creates one per call, started from zero flow.
double both_directions(const cv::Mat &a, const cv::Mat &b, const matching::FlowSearchOptions &o, int steps,
                       bool propagation, int runs) {
    return bench::median_seconds(runs, [&] {
        for (int dir = 0; dir < 2; ++dir) {
            cv::Ptr<cv::DISOpticalFlow> dis = matching::flow_search(dir == 0 ? o : o.backward());
            dis->setGradientDescentIterations(steps);
            dis->setUseSpatialPropagation(propagation);
            cv::Mat2f flow(a.size(), cv::Vec2f(0, 0));
            dis->calc(dir == 0 ? a : b, dir == 0 ? b : a, flow);
        }
    });
}

}  // namespace

int main(int argc, char **argv) try {
    std::string root, preset = "realtime";
    std::vector<std::string> ids{"000002", "000003"};
    int runs = 9, threads = 2;
    bench::for_each_flag(argc, argv, usage, [&](const std::string &a, const auto &next) {
        if (a == "--root") root = next();
        else if (a == "--ids") ids = cli::split_list(next());
        else if (a == "--preset") preset = next();
        else if (a == "--runs") runs = std::max(1, std::atoi(next().c_str()));
        else if (a == "--threads") threads = std::max(1, std::atoi(next().c_str()));
        else usage(("unknown argument " + a).c_str());
    });
    if (root.empty()) usage("--root is required");
    const pipeline::EstimatorOptions opt = pipeline::EstimatorOptions::preset(preset);
    if (opt.matching.method != matching::MatchMethod::Decoupled) usage("--preset: a decoupled preset (DIS)");
    const matching::FlowSearchOptions &o = opt.matching.flow;
    cv::setNumThreads(threads);
    std::printf("bench_flow: preset %s (scale %.2f, patch %d, stride %d / backward %d, %d steps, finest level %d), "
                "%d thread(s), median of %d, both directions\n",
                preset.c_str(), opt.processing_scale, o.patch_size, o.patch_stride, o.backward().patch_stride,
                o.descent_iterations, o.finest_scale, threads, runs);
    std::printf("%-7s %-9s %9s %12s %9s\n", "frame", "size", "search", "fixed part", "steps");
    for (const std::string &id : ids) {
        const eval::KittiFrame f = eval::load_kitti_frame(root, id, eval::LidarInputOptions{});
        const cv::Size size = pipeline::scaled_size(f.input.left0.cols, f.input.left0.rows, opt.processing_scale);
        const pipeline::FrameInput small =
            size == f.input.left0.size() ? f.input : pipeline::downscale_frame(f.input, size);
        const cv::Mat g0 = gray8(small.left0), g1 = gray8(small.left1);
        const double full = both_directions(g0, g1, o, o.descent_iterations, true, runs);
        const double fixed = both_directions(g0, g1, o, 1, false, runs);
        std::printf("%-7s %4dx%-4d %7.4f s %10.4f s %7.4f s\n", id.c_str(), size.width, size.height, full, fixed,
                    full - fixed);
    }
    return 0;
} catch (const std::exception &e) {
    std::fprintf(stderr, "bench_flow: %s\n", e.what());
    return 1;
}
