// SPDX-License-Identifier: MIT
#pragma once
// Rectification of raw stereo pairs (a Rig with rectify set): undistorts each image and turns it
// into the rectified camera of its P, so the pair's epipolar lines become rows. The remap tables
// are computed once per rig and image size, so a frame costs two cv::remap calls.
#include <opencv2/core.hpp>

#include "io/rig.hpp"

namespace lidarflow::io {

class Rectifier {
public:
    // Tables for raw images of `size` (the rectified images have the same size). Throws
    // Error(InvalidArgument) for an empty size or one above core/limits.hpp's kMaxImageSide.
    Rectifier(const Rig &rig, cv::Size size);

    cv::Size size() const { return size_; }

    // The rectified pair of a raw pair of size() (8-bit gray or BGR; the outputs may be the
    // inputs); bilinear, pixels that no
    // raw pixel reaches are black. Const and thread-safe: the tables are only read.
    void apply(const cv::Mat &left, const cv::Mat &right, cv::Mat &left_out, cv::Mat &right_out) const;

private:
    cv::Size size_;
    // cv::initUndistortRectifyMap tables (CV_16SC2 + CV_16UC1); empty for a camera whose images
    // are rectified already (no distortion, R = I, P's 3x3 = K), which is then copied unchanged.
    cv::Mat left_xy_, left_frac_, right_xy_, right_frac_;
};

}  // namespace lidarflow::io
