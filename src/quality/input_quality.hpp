// SPDX-License-Identifier: MIT
#pragma once
// Whether a frame's inputs look like what the estimator assumes: a rectified stereo pair in the
// right order, images with content, a calibration of the images' size, and a LiDAR that the
// images agree with. The estimator happily turns wrong inputs into a dense, confident-looking
// result; these cheap checks (a few milliseconds on a small copy of the images) say so.
// Values of Flag are the bits of the C ABI's lf_quality_t (include/lidarflow/lidarflow.h).
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"

namespace lidarflow::quality {

enum Flag : uint32_t {
    LeftRightSwapped = 1u << 0,
    NotRectified = 1u << 1,
    CalibrationSizeMismatch = 1u << 2,
    BlankFrame = 1u << 3,
    LidarDisagrees = 1u << 4,
};
constexpr uint32_t kAllFlags = (1u << 5) - 1;

// "left_right_swapped", ...; "unknown" for anything but one defined bit.
const char *flag_name(uint32_t flag);

struct Report {
    uint32_t flags = 0;   // 0 = ok
    std::string reason;   // one clause per flag, "; "-separated, in bit order; "" when ok

    bool ok() const { return flags == 0; }
    void add(Flag f, const std::string &why);
    // "ok", or "STATE[, STATE...] (reason)": the CLI's and the logs' one line.
    std::string summary() const;
};

// Counts of results by state, for the summaries of streams.
struct Tally {
    long ok = 0;
    long flagged[5] = {};  // by bit position of Flag
    void add(uint32_t flags);
    // "12 ok, 1 blank_frame, 2 lidar_disagrees" (states never seen are left out; "0 ok" when empty).
    std::string text() const;
};

// What the checks read: the frame as the estimator receives it (8-bit gray or BGR images of one
// size) and the points it uses.
struct Input {
    cv::Mat left0, right0, left1, right1;
    const SparseLidar *lidar0 = nullptr;  // may be null or empty
    cv::Size calibration_size;            // the size the calibration describes; 0 = unknown
    int threads = 1;                      // OpenMP threads of the LiDAR check (same result on any count)
};

// Each check returns its reason, or "" when it finds nothing wrong.

// Calibration of one size, images of another (a side of 0 = unknown: no judgement).
std::string calibration_size_mismatch(cv::Size calibration, cv::Size image);

// An image without content (black, saturated, uniform), or t1 bit-identical to t0 (frozen).
std::string blank_frame(const Input &in);

// Sparse left -> right matches (corners found on a half-size copy and tracked with pyramidal
// Lucas-Kanade, kept where the track back lands where it started), in full-resolution pixels.
struct StereoMatches {
    int count = 0;          // round-trip consistent matches
    int positive = 0;       // of them with disparity x_left - x_right >= 1 px
    int negative = 0;       // and <= -1 px
    double median_abs_dy = 0;  // median |y_right - y_left| [px]
};
StereoMatches match_stereo_features(const cv::Mat1b &left, const cv::Mat1b &right, double to_full_resolution);
std::string left_right_swapped(const StereoMatches &m);
std::string not_rectified(const StereoMatches &m);

// The LiDAR disparities against the image pair's own block matching at the LiDAR pixels.
struct LidarAgreement {
    int decided = 0;          // points whose image match is textured and unique
    double residual_p75 = 0;  // 3rd quartile of their |LiDAR - image| disparity [full-resolution px]
};
LidarAgreement lidar_agreement(const cv::Mat1b &left, const cv::Mat1b &right, const SparseLidar &lidar,
                               double scale, int threads = 1);
std::string lidar_disagrees(const LidarAgreement &a);

// The checks of one stereo pair and its points (a frame alone): the order and rectification
// of its images, then, when both hold, its LiDAR. Nothing is measured on a frame too small.
struct StereoCheck {
    StereoMatches matches;
    LidarAgreement lidar;
    std::string swapped, skewed, lidar_disagrees;  // each check's reason, "" when it finds nothing
};
StereoCheck check_stereo(const cv::Mat &left0, const cv::Mat &right0, const SparseLidar *lidar0, int threads = 1);
// Every check on one frame. The LiDAR check is skipped when the images themselves are wrong
// (it would only repeat that). t0: check_stereo of in's t0 images and lidar0 when already
// computed (a stream's first frame, ahead of its pair), else null. Never throws for
// well-formed inputs.
Report assess(const Input &in, const StereoCheck *t0 = nullptr);

}  // namespace lidarflow::quality
