// SPDX-License-Identifier: MIT
#include "consistency/sgm_check.hpp"

#include <climits>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include "consistency/validate.hpp"
#include "core/error.hpp"

namespace lidarflow::consistency {

DisparityMap compute_sgm_disparity(const cv::Mat &left, const cv::Mat &right, const SgmOptions &opt) {
    require(!left.empty() && !right.empty(), ErrorCode::InvalidArgument, "SGM: empty image");
    require(left.depth() == CV_8U && (left.channels() == 1 || left.channels() == 3), ErrorCode::InvalidArgument,
            "SGM: images must be 8-bit gray or BGR");
    require(left.size() == right.size() && left.type() == right.type(), ErrorCode::SizeMismatch,
            "SGM: left and right images differ in size or type");
    ConsistencyOptions check;
    check.sgm = opt;
    detail::check_options(check);

    const int cn = left.channels(), b = opt.block_size;
    cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(
        0, opt.num_disparities, b, 8 * cn * b * b, 32 * cn * b * b, opt.disp12_max_diff, 63,
        opt.uniqueness_ratio, opt.speckle_window, opt.speckle_range,
        opt.full_dp ? cv::StereoSGBM::MODE_HH : cv::StereoSGBM::MODE_SGBM_3WAY);

    // SGBM leaves the leftmost num_disparities columns undefined; padding the left border lets
    // them be matched against the part of I_r^0 that exists (the padded part repeats the edge
    // and costs the same for every candidate, so it cannot win over a real match by texture).
    const int pad = opt.pad_left_border ? opt.num_disparities : 0;
    // OpenCV's speckle filter keeps pixel coordinates in 16-bit integers: a wider or taller
    // image overwrites its heap (65535x2 frames crashed). The estimator's own bound on image
    // sides keeps far below this; other callers get an error instead of the corruption.
    require(left.cols + pad <= SHRT_MAX && left.rows <= SHRT_MAX, ErrorCode::InvalidArgument, [&] {
        return "SGM: " + std::to_string(left.cols) + "x" + std::to_string(left.rows) + " images (+" +
               std::to_string(pad) + " px padding) exceed the " + std::to_string(SHRT_MAX) +
               " px per side OpenCV's SGBM handles";
    });
    cv::Mat l = left, r = right;
    if (pad > 0) {
        cv::copyMakeBorder(left, l, 0, 0, pad, 0, cv::BORDER_REPLICATE);
        cv::copyMakeBorder(right, r, 0, 0, pad, 0, cv::BORDER_REPLICATE);
    }
    cv::Mat disp16;
    sgbm->compute(l, r, disp16);
    CV_Assert(disp16.type() == CV_16S);
    DisparityMap out(left.rows, left.cols, kInvalidDisparity);
    for (int y = 0; y < left.rows; ++y) {
        const short *row = disp16.ptr<short>(y) + pad;
        for (int x = 0; x < left.cols; ++x)
            // Rejected pixels hold (minDisparity - 1) * 16 = -16; disparities pointing past
            // the left border of I_r^0 cannot be right.
            if (row[x] >= 0 && row[x] <= 16 * x) out(y, x) = row[x] / 16.0f;
    }
    return out;
}

SceneFlowField sgm_check(const SceneFlowField &forward, const DisparityMap &sgm, const LidarReference &lidar,
                         const ConsistencyOptions &opt) {
    detail::check_options(opt);
    detail::check_field(forward, "forward");
    const int h = forward.height(), w = forward.width();
    detail::check_size(sgm, h, w, "SGM disparity");
    detail::check_size(lidar.is_lidar, h, w, "LiDAR mask");
    detail::check_size(lidar.in_window, h, w, "support-window mask");

    SceneFlowField out = detail::empty_like(forward);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float s = sgm(y, x);
            require(std::isfinite(s), ErrorCode::InvalidArgument, "consistency: non-finite SGM disparity");
            if (!forward.valid(y, x)) continue;
            bool keep;
            if (lidar.in_window(y, x))  // LiDAR pixels lie in their own window
                keep = true;
            else if (!disparity_valid(s))
                keep = opt.sgm_keep_unverified;
            else
                keep = std::fabs(forward.d0(y, x) - s) <= opt.sgm_max_diff;
            if (keep) detail::keep_match(out, forward, y, x);
        }
    return out;
}

}  // namespace lidarflow::consistency
