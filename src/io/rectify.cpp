// SPDX-License-Identifier: MIT
#include "io/rectify.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "core/size_text.hpp"

namespace lidarflow::io {
namespace {

bool unchanged(const RawCamera &c) {
    return c.D == cv::Vec<double, 8>::all(0) && c.R == cv::Matx33d::eye() && c.K == c.P.get_minor<3, 3>(0, 0);
}

void make_tables(const RawCamera &c, cv::Size size, cv::Mat &xy, cv::Mat &frac) {
    if (unchanged(c)) return;
    // Fixed-point tables: remap with them is several times faster than with float maps.
    cv::initUndistortRectifyMap(cv::Mat(c.K), cv::Mat(c.D), cv::Mat(c.R), cv::Mat(c.P), size, CV_16SC2, xy, frac);
}

void rectify(const cv::Mat &in, const cv::Mat &xy, const cv::Mat &frac, cv::Mat &out) {
    if (xy.empty())
        out = in.clone();
    else
        cv::remap(in, out, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
}

}  // namespace

Rectifier::Rectifier(const Rig &rig, cv::Size size) : size_(size) {
    require(size.width > 0 && size.height > 0 && size.width <= kMaxImageSide && size.height <= kMaxImageSide,
            ErrorCode::InvalidArgument,
            "rectifier: image size " + size_text(size) + " out of range");
    make_tables(rig.left, size, left_xy_, left_frac_);
    make_tables(rig.right, size, right_xy_, right_frac_);
}

void Rectifier::apply(const cv::Mat &left, const cv::Mat &right, cv::Mat &left_out, cv::Mat &right_out) const {
    require(left.size() == size_ && right.size() == size_, ErrorCode::SizeMismatch,
            "rectifier: the pair is not the size its tables were made for");
    // cv::remap cannot write into its input, and callers pass the same Mats in and out.
    cv::Mat l, r;
    rectify(left, left_xy_, left_frac_, l);
    rectify(right, right_xy_, right_frac_, r);
    left_out = l;
    right_out = r;
}

}  // namespace lidarflow::io
