// SPDX-License-Identifier: MIT
// The calibration readers of io/rig.cpp on text in memory: the OpenCV stereo file on the whole
// input, the camera_info pair on its two halves (split at the first "\n%%\n", else the input
// twice). Each either throws lidarflow::Error or returns a rig whose rectified camera lies in
// the ranges of core/limits.hpp; a rig to rectify gets its tables made and applied at a small
// size (cv::initUndistortRectifyMap / cv::remap on what the reader let through).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "io/rectify.hpp"
#include "io/rig.hpp"

namespace {

void check(const lidarflow::io::Rig &rig) {
    using namespace lidarflow;
    const StereoCamera &k = rig.rect.camera;
    if (!(k.fx >= kMinFocal && k.fx <= kMaxFocal && k.fy >= kMinFocal && k.fy <= kMaxFocal)) std::abort();
    if (!(std::fabs(k.cx) <= kMaxPrincipalPoint && std::fabs(k.cy) <= kMaxPrincipalPoint)) std::abort();
    if (!(k.baseline >= kMinBaseline && k.baseline <= kMaxBaseline)) std::abort();
    const cv::Size s = rig.rect.image_size;
    if (s.width < 0 || s.height < 0 || s.width > kMaxImageSide || s.height > kMaxImageSide) std::abort();
    if (!rig.rectify) return;
    const io::Rectifier r(rig, {24, 16});
    cv::Mat left(16, 24, CV_8UC1, cv::Scalar(9)), right(16, 24, CV_8UC3, cv::Scalar(1, 2, 3));
    r.apply(left, right, left, right);
    if (left.size() != cv::Size(24, 16) || right.type() != CV_8UC3) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string text(reinterpret_cast<const char *>(data), size);
    try {
        check(lidarflow::io::parse_opencv_stereo(text, "fuzz"));
    } catch (const lidarflow::Error &) {
    }
    const size_t cut = text.find("\n%%\n");
    const std::string left = cut == std::string::npos ? text : text.substr(0, cut + 1);
    const std::string right = cut == std::string::npos ? text : text.substr(cut + 4);
    try {
        check(lidarflow::io::parse_camera_info_pair(left, "left", right, "right"));
    } catch (const lidarflow::Error &) {
    }
    return 0;
}
