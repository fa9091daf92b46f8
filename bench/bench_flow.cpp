// SPDX-License-Identifier: MIT
// The decoupled stage 1's flow search as it runs: the project's dense inverse search
// (flow/dis.hpp) beside OpenCV's DISOpticalFlow at a preset's settings on the reduced KITTI frames
// (gray, both directions as the matcher searches them, started from zero flow), runs alternated;
// and whether the two flows are the same bits (they must be).
//
//   bench_flow --root DIR [--ids 000002,000003] [--preset realtime|fast|default] [--runs 9]
//              [--threads 2]
#include <algorithm>
#include <chrono>
#include <cstring>
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
#include "flow/dis.hpp"
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

// Both directions (from -> to with o, then to -> from with o.backward()) started from zero flow:
// with OpenCV's DIS (a fresh one per call, as the matcher creates them) or ours.
std::vector<cv::Mat2f> both_directions(const cv::Mat &a, const cv::Mat &b, const matching::FlowSearchOptions &o,
                                       bool own, int threads) {
    std::vector<cv::Mat2f> out;
    for (int dir = 0; dir < 2; ++dir) {
        const matching::FlowSearchOptions d = dir == 0 ? o : o.backward();
        const cv::Mat &from = dir == 0 ? a : b, &to = dir == 0 ? b : a;
        cv::Mat2f flow(a.size(), cv::Vec2f(0, 0));
        if (own) {
            flow = flow::dis_flow(from, to, {d.finest_scale, d.patch_size, d.patch_stride, d.descent_iterations, threads},
                                  flow);
        } else {
            cv::Ptr<cv::DISOpticalFlow> dis = matching::flow_search(d);
            dis->calc(from, to, flow);
        }
        out.push_back(flow);
    }
    return out;
}

bool same_bits(const std::vector<cv::Mat2f> &x, const std::vector<cv::Mat2f> &y) {
    for (size_t i = 0; i < x.size(); ++i)
        if (x[i].size() != y[i].size() || std::memcmp(x[i].data, y[i].data, x[i].total() * sizeof(cv::Vec2f)) != 0)
            return false;
    return true;
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
                "%d thread(s), median of %d alternated runs, both directions\n",
                preset.c_str(), opt.processing_scale, o.patch_size, o.patch_stride, o.backward().patch_stride,
                o.descent_iterations, o.finest_scale, threads, runs);
    std::printf("%-7s %-9s %12s %12s %7s  %s\n", "frame", "size", "OpenCV DIS", "flow/dis", "ratio", "flow");
    for (const std::string &id : ids) {
        const eval::KittiFrame f = eval::load_kitti_frame(root, id, eval::LidarInputOptions{});
        const cv::Size size = pipeline::scaled_size(f.input.left0.cols, f.input.left0.rows, opt.processing_scale);
        const pipeline::FrameInput small =
            size == f.input.left0.size() ? f.input : pipeline::downscale_frame(f.input, size);
        const cv::Mat g0 = gray8(small.left0), g1 = gray8(small.left1);
        std::vector<double> theirs, ours;
        for (int r = 0; r < runs; ++r)
            for (bool own : {false, true}) {
                const auto t0 = std::chrono::steady_clock::now();
                both_directions(g0, g1, o, own, threads);
                (own ? ours : theirs).push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            }
        const double a = bench::median(theirs), b = bench::median(ours);
        const bool same = same_bits(both_directions(g0, g1, o, false, threads), both_directions(g0, g1, o, true, threads));
        std::printf("%-7s %4dx%-4d %10.2f ms %9.2f ms %6.2fx  %s\n", id.c_str(), size.width, size.height, 1e3 * a,
                    1e3 * b, a / b, same ? "identical" : "DIFFERENT");
        if (!same) return 1;
    }
    return 0;
} catch (const std::exception &e) {
    std::fprintf(stderr, "bench_flow: %s\n", e.what());
    return 1;
}
