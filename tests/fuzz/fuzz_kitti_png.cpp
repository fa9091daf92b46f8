// SPDX-License-Identifier: MIT
// The KITTI PNG readers (src/io/kitti_png.cpp): disparity (16-bit gray), flow (16-bit RGB) and
// 8-bit images, all three on every input. They take paths, so the input goes through a scratch
// file. Each either throws lidarflow::Error or returns values its format allows; bytes that do
// not start with the PNG signature (any other format OpenCV knows, too) are refused by all three.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iostream>

#include "core/error.hpp"
#include "fuzz_support.hpp"
#include "io/kitti_png.hpp"

extern "C" int LLVMFuzzerInitialize(int *, char ***) {
    // A PNG header can declare 2^30 pixels in a few bytes; OpenCV then allocates them all
    // before finding the data short. Bounded here so that libFuzzer's memory limit reports
    // real leaks and overruns, not this.
    setenv("OPENCV_IO_MAX_IMAGE_PIXELS", "4194304", 1);
    // OpenCV 4.6's imread reports every unreadable header on std::cerr; libFuzzer and the
    // sanitizers write to fd 2 directly and stay visible.
    std::cerr.rdbuf(nullptr);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string &path = lidarflow::fuzz::write_scratch(data, size, ".png");
    static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    const bool png = size >= 8 && std::memcmp(data, kSignature, 8) == 0;
    try {
        const lidarflow::DisparityMap d = lidarflow::io::read_disparity_png(path);
        if (!png) std::abort();
        for (int y = 0; y < d.rows; ++y)
            for (int x = 0; x < d.cols; ++x) {
                const float v = d(y, x);
                if (!(v == lidarflow::kInvalidDisparity || (v >= 1.0f / 256 && v <= 65535.0f / 256))) std::abort();
            }
    } catch (const lidarflow::Error &) {
    }
    try {
        const lidarflow::FlowField f = lidarflow::io::read_flow_png(path);
        if (!png) std::abort();
        for (int y = 0; y < f.height(); ++y)
            for (int x = 0; x < f.width(); ++x) {
                if (f.valid(y, x) > 1) std::abort();
                if (f.valid(y, x) && !(std::fabs(f.u(y, x)) <= 512 && std::fabs(f.v(y, x)) <= 512)) std::abort();
            }
    } catch (const lidarflow::Error &) {
    }
    try {
        const cv::Mat m = lidarflow::io::read_image(path);
        if (!png) std::abort();
        if (m.empty() || m.depth() != CV_8U || (m.channels() != 1 && m.channels() != 3)) std::abort();
    } catch (const lidarflow::Error &) {
    }
    return 0;
}
