// SPDX-License-Identifier: MIT
// The estimator's frame reduction (core/area_downscale) beside the library call it replaces,
// cv::resize with INTER_AREA: median time per image at the presets' processing scales, on the
// KITTI frames (--root) or, without them, a 1242x375 noise image; and whether the bytes agree.
//
//   bench_downscale [--root DIR] [--ids 000002,000003] [--runs 31] [--threads 2]
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "args.hpp"
#include "bench_util.hpp"
#include "core/area_downscale.hpp"
#include "pipeline/resolution.hpp"

using namespace lidarflow;

namespace {

[[noreturn]] void usage(const char *msg) {
    std::fprintf(stderr, "%s\nusage: bench_downscale [--root DIR] [--ids A,B] [--runs N] [--threads N]\n", msg);
    std::exit(2);
}

}  // namespace

int main(int argc, char **argv) try {
    std::string root;
    std::vector<std::string> ids{"000002", "000003"};
    int runs = 31, threads = 2;
    bench::for_each_flag(argc, argv, usage, [&](const std::string &a, const auto &next) {
        if (a == "--root") root = next();
        else if (a == "--ids") ids = cli::split_list(next());
        else if (a == "--runs") runs = std::max(1, std::atoi(next().c_str()));
        else if (a == "--threads") threads = std::max(1, std::atoi(next().c_str()));
        else usage(("unknown argument " + a).c_str());
    });
    cv::setNumThreads(threads);
    std::vector<std::pair<std::string, cv::Mat>> images;
    if (root.empty()) {
        cv::Mat noise(375, 1242, CV_8UC3);
        cv::randu(noise, 0, 256);
        images.emplace_back("noise", noise);
    }
    for (const std::string &id : root.empty() ? std::vector<std::string>{} : ids) {
        const cv::Mat image = cv::imread(root + "/image_2/" + id + "_10.png", cv::IMREAD_UNCHANGED);
        if (image.empty()) usage(("cannot read frame " + id + " under --root").c_str());
        images.emplace_back(id, image);
    }
    std::printf("bench_downscale: %d thread(s), median of %d, one image\n", threads, runs);
    std::printf("%-7s %-10s %-9s %12s %14s %7s  %s\n", "image", "size", "to", "cv::resize", "area_downscale",
                "ratio", "bytes");
    for (const auto &entry : images)
        for (double scale : {0.55, 0.65}) {
            // Plain names, not a structured binding: the lambdas below capture them (C++17).
            const std::string &name = entry.first;
            const cv::Mat &image = entry.second;
            const cv::Size size = pipeline::scaled_size(image.cols, image.rows, scale);
            cv::Mat a, b;
            const double theirs = bench::median_seconds(runs, [&] { cv::resize(image, a, size, 0, 0, cv::INTER_AREA); });
            const double ours = bench::median_seconds(runs, [&] { area_downscale(image, b, size, threads); });
            std::printf("%-7s %4dx%-5d %4dx%-4d %9.2f ms %11.2f ms %6.2fx  %s\n", name.c_str(), image.cols, image.rows,
                        size.width, size.height, 1e3 * theirs, 1e3 * ours, theirs / ours,
                        cv::norm(a, b, cv::NORM_INF) == 0 ? "identical" : "DIFFER");
        }
    return 0;
} catch (const std::exception &e) {
    std::fprintf(stderr, "bench_downscale: %s\n", e.what());
    return 1;
}
