// SPDX-License-Identifier: MIT
#include "consistency/sgm_check.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <new>

#include <sys/resource.h>
#include <unistd.h>

#include <opencv2/calib3d.hpp>

#include "consistency/steps.hpp"
#include "consistency/validate.hpp"
#include "core/error.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency {
namespace {

// Bytes of address space the process may still map under RLIMIT_AS (`ulimit -v`), or SIZE_MAX
// without a limit or when it cannot be read.
size_t address_space_headroom() {
    struct rlimit lim;
    if (getrlimit(RLIMIT_AS, &lim) != 0 || lim.rlim_cur == RLIM_INFINITY) return SIZE_MAX;
    std::FILE *f = std::fopen("/proc/self/statm", "r");
    if (!f) return SIZE_MAX;
    unsigned long pages = 0;
    const bool ok = std::fscanf(f, "%lu", &pages) == 1;
    std::fclose(f);
    if (!ok) return SIZE_MAX;
    const size_t used = static_cast<size_t>(pages) * static_cast<size_t>(sysconf(_SC_PAGESIZE));
    return used >= lim.rlim_cur ? 0 : static_cast<size_t>(lim.rlim_cur) - used;
}

// OpenCV 4.6's SGBM ends the process (std::terminate) when one of its scratch buffers cannot be
// allocated: its cv::utils::BufferArea asserts in the destructor that runs after the failed
// allocation (later OpenCV releases dropped that assertion). Under an address-space limit,
// where malloc does fail, the headroom is checked first and a shortfall reported as
// std::bad_alloc (LF_ERR_OUT_OF_MEMORY in the C ABI). The need is bounded generously: each
// OpenCV worker holds a few 16-bit cost lines (pixels x disparities) and block + 1 lines of
// partial sums; counted as block + 8 lines (~1.3x that) per worker, times 1.5 (~4.5 MB per
// worker on a padded KITTI row). Without a limit this costs one getrlimit call.
void require_sgm_headroom(int width, int num_disparities, int block_size) {
    const size_t line = static_cast<size_t>(width + num_disparities + 2) * num_disparities * sizeof(short);
    const size_t per_worker = line * static_cast<size_t>(block_size + 8);
    const size_t need = per_worker * static_cast<size_t>(std::max(1, cv::getNumThreads())) * 3 / 2;
    if (address_space_headroom() < need) throw std::bad_alloc();
}

void check_sgm_images(const cv::Mat &left, const cv::Mat &right) {
    require(!left.empty() && !right.empty(), ErrorCode::InvalidArgument, "SGM: empty image");
    require(left.depth() == CV_8U && (left.channels() == 1 || left.channels() == 3), ErrorCode::InvalidArgument,
            "SGM: images must be 8-bit gray or BGR");
    require(left.size() == right.size() && left.type() == right.type(), ErrorCode::SizeMismatch,
            "SGM: left and right images differ in size or type");
}

// compute_sgm_disparity on checked images and settings.
DisparityMap sgm_disparity(const cv::Mat &left, const cv::Mat &right, const SgmOptions &opt) {
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
    cv::Mat disp16(l.size(), CV_16S);  // allocated here, where a failure throws cleanly
    require_sgm_headroom(l.cols, opt.num_disparities, b);
    sgbm->compute(l, r, disp16);
    CV_Assert(disp16.type() == CV_16S);
    DisparityMap out = filled(left.rows, left.cols, kInvalidDisparity);
    for (int y = 0; y < left.rows; ++y) {
        const short *row = disp16.ptr<short>(y) + pad;
        for (int x = 0; x < left.cols; ++x)
            // Rejected pixels hold (minDisparity - 1) * 16 = -16; disparities pointing past
            // the left border of I_r^0 cannot be right.
            if (row[x] >= 0 && row[x] <= 16 * x) out(y, x) = row[x] / 16.0f;
    }
    return out;
}

}  // namespace

DisparityMap compute_sgm_disparity(const cv::Mat &left, const cv::Mat &right, const SgmOptions &opt) {
    check_sgm_images(left, right);
    ConsistencyOptions check;
    check.sgm = opt;
    detail::check_options(check);
    return sgm_disparity(left, right, opt);
}

DisparityMap detail::compute_sgm_disparity(const cv::Mat &left, const cv::Mat &right, const CheckedOptions &checked) {
    check_sgm_images(left, right);
    return sgm_disparity(left, right, checked.get().sgm);
}

SceneFlowField detail::sgm_check(const SceneFlowField &forward, const DisparityMap &sgm, const LidarReference &lidar,
                                 const CheckedOptions &checked) {
    const ConsistencyOptions &opt = checked.get();
    detail::check_field(forward, "forward");
    const int h = forward.height(), w = forward.width();
    detail::check_size(sgm, h, w, "SGM disparity");
    detail::check_size(lidar.is_lidar, h, w, "LiDAR mask");
    detail::check_size(lidar.in_window, h, w, "support-window mask");

    for (int y = 0; y < h; ++y)
        require(std::all_of(sgm[y], sgm[y] + w, [](float s) { return std::isfinite(s); }), ErrorCode::InvalidArgument,
                "consistency: non-finite SGM disparity");
    SceneFlowField out = SceneFlowField::uninitialized(w, h);  // each row cleared where it is filled
#pragma omp parallel for schedule(static) num_threads(std::max(1, opt.threads))
    for (int y = 0; y < h; ++y) {
        out.clear_row(y);
        for (int x = 0; x < w; ++x) {
            const float s = sgm(y, x);
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
    }
    return out;
}

SceneFlowField sgm_check(const SceneFlowField &forward, const DisparityMap &sgm, const LidarReference &lidar,
                         const ConsistencyOptions &opt) {
    return detail::sgm_check(forward, sgm, lidar, detail::CheckedOptions(opt));
}

}  // namespace lidarflow::consistency
