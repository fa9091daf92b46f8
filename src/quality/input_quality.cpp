// SPDX-License-Identifier: MIT
#include "quality/input_quality.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include <omp.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "core/gray.hpp"
#include "core/log.hpp"
#include "core/size_text.hpp"

namespace lidarflow::quality {
namespace {

// The checks run on a copy at most this wide: their cost stays a few ms at any input size.
constexpr int kWorkWidth = 640;
// Below this intensity spread (std. dev. of gray levels) an image shows nothing to match.
constexpr double kBlankStddev = 2.5;
// Decisions need this many matches (or LiDAR points); fewer say nothing.
constexpr int kMinMatches = 15;
constexpr int kMinLidar = 12;
// Working images smaller than this per side are not matched.
constexpr int kMinSide = 32;

std::string format(const char *fmt, double a, double b = 0, double c = 0) {
    char buf[200];
    std::snprintf(buf, sizeof buf, fmt, a, b, c);
    return buf;
}

// An integer reduction, which INTER_AREA does as a plain box average.
double work_scale(cv::Size s) { return 1.0 / std::max(1, (s.width + kWorkWidth - 1) / kWorkWidth); }

cv::Mat1b work_gray(const cv::Mat &image, double scale) {
    if (scale >= 1.0) return gray8(image);
    cv::Mat small;
    cv::resize(image, small, cv::Size(), scale, scale, cv::INTER_AREA);
    return gray8(small);
}

// Standard deviation (and *mean) of every channel's values on every 8th pixel of every 8th row:
// enough to tell an image from a blank one.
double spread(const cv::Mat &image, double *mean) {
    const int step = 8;
    double s = 0, s2 = 0;
    size_t n = 0;
    const int ch = image.channels();
    for (int y = 0; y < image.rows; y += step) {
        const uint8_t *row = image.ptr<uint8_t>(y);
        for (int x = 0; x < image.cols; x += step)
            for (int c = 0; c < ch; ++c) {
                const double v = row[x * ch + c];
                s += v;
                s2 += v * v;
                ++n;
            }
    }
    const double m = s / static_cast<double>(n);
    *mean = m;
    return std::sqrt(std::max(0.0, s2 / static_cast<double>(n) - m * m));
}

bool identical(const cv::Mat &a, const cv::Mat &b) {
    if (a.size() != b.size() || a.type() != b.type()) return false;
    for (int y = 0; y < a.rows; ++y)
        if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
    return true;
}

// The q-quantile (0 for no values).
double quantile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    const auto at = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), at, v.end());
    return *at;
}

// Zero-mean normalised cross-correlation of the (2r+1)^2 patches at (xl, y) and (xr, y).
double zncc(const cv::Mat1b &l, const cv::Mat1b &r, int xl, int xr, int y, int rad, double ml, double sl) {
    double sr = 0, sr2 = 0, slr = 0;
    const int n = (2 * rad + 1) * (2 * rad + 1);
    for (int dy = -rad; dy <= rad; ++dy) {
        const uint8_t *pl = l.ptr<uint8_t>(y + dy);
        const uint8_t *pr = r.ptr<uint8_t>(y + dy);
        for (int dx = -rad; dx <= rad; ++dx) {
            const double a = pl[xl + dx], b = pr[xr + dx];
            sr += b;
            sr2 += b * b;
            slr += a * b;
        }
    }
    const double mr = sr / n;
    const double vr = sr2 / n - mr * mr;
    if (vr < 1e-6) return -1;
    return (slr / n - ml * mr) / (sl * std::sqrt(vr));
}

}  // namespace

const char *flag_name(uint32_t flag) {
    switch (flag) {
    case LeftRightSwapped: return "left_right_swapped";
    case NotRectified: return "not_rectified";
    case CalibrationSizeMismatch: return "calibration_size_mismatch";
    case BlankFrame: return "blank_frame";
    case LidarDisagrees: return "lidar_disagrees";
    default: return "unknown";
    }
}

void Report::add(Flag f, const std::string &why) {
    flags |= f;
    if (!reason.empty()) reason += "; ";
    reason += why;
}

std::string Report::summary() const {
    if (ok()) return "ok";
    std::string s;
    for (uint32_t bit = 1; bit <= kAllFlags; bit <<= 1)
        if (flags & bit) s += (s.empty() ? "" : ", ") + std::string(flag_name(bit));
    return s + " (" + reason + ")";
}

void Tally::add(uint32_t flags) {
    if (flags == 0) ++ok;
    for (int b = 0; b < 5; ++b)
        if (flags & (1u << b)) ++flagged[b];
}

std::string Tally::text() const {
    std::string s = std::to_string(ok) + " ok";
    for (int b = 0; b < 5; ++b)
        if (flagged[b]) s += ", " + std::to_string(flagged[b]) + " " + flag_name(1u << b);
    return s;
}

std::string calibration_size_mismatch(cv::Size calibration, cv::Size image) {
    if (calibration.width <= 0 || calibration.height <= 0 || image.width <= 0 || image.height <= 0) return "";
    if (calibration == image) return "";
    return "the calibration is for " + size_text(calibration) + " images, these are " + size_text(image);
}

std::string blank_frame(const Input &in) {
    const cv::Mat *imgs[4] = {&in.left0, &in.right0, &in.left1, &in.right1};
    const char *names[4] = {"left0", "right0", "left1", "right1"};
    std::string why;
    for (int i = 0; i < 4; ++i) {
        if (imgs[i]->empty()) continue;
        double mean = 0;
        const double sd = spread(*imgs[i], &mean);
        if (sd >= kBlankStddev) continue;
        const char *what = mean < 16 ? "black" : mean > 239 ? "saturated" : "uniform";
        why += (why.empty() ? "" : ", ") + std::string(names[i]) + " is " + what +
               format(" (mean %.0f, spread %.1f gray levels)", mean, sd);
    }
    if (why.empty() && identical(in.left0, in.left1) && identical(in.right0, in.right1))
        why = "the t1 images are identical to t0 (a frozen camera)";
    return why;
}

StereoMatches match_stereo_features(const cv::Mat1b &left, const cv::Mat1b &right, double to_full_resolution) {
    StereoMatches m;
    std::vector<cv::Point2f> corners;
    // Corners found on a half-size copy (a quarter of the corner measure's cost), tracked at this
    // size: the statistics below do not need their exact pixel, only texture around it.
    if (left.cols >= 2 * kMinSide && left.rows >= 2 * kMinSide) {
        cv::Mat1b half;
        cv::resize(left, half, cv::Size(left.cols / 2, left.rows / 2), 0.0, 0.0, cv::INTER_AREA);
        cv::goodFeaturesToTrack(half, corners, 100, 0.01, 6, cv::noArray(), 3);
        for (cv::Point2f &c : corners) c = c * 2.0f + cv::Point2f(0.5f, 0.5f);  // the half pixel's centre here
    } else {
        cv::goodFeaturesToTrack(left, corners, 100, 0.01, 12, cv::noArray(), 5);
    }
    if (corners.size() < static_cast<size_t>(kMinMatches)) return m;
    std::vector<cv::Point2f> there, back;
    std::vector<uint8_t> ok_there, ok_back;
    std::vector<float> err;
    const cv::Size win(11, 11);
    const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);
    // Each pyramid built once for both directions.
    std::vector<cv::Mat> pyr_left, pyr_right;
    const int levels = cv::buildOpticalFlowPyramid(left, pyr_left, win, 4);
    cv::buildOpticalFlowPyramid(right, pyr_right, win, levels);
    cv::calcOpticalFlowPyrLK(pyr_left, pyr_right, corners, there, ok_there, err, win, levels, stop);
    cv::calcOpticalFlowPyrLK(pyr_right, pyr_left, there, back, ok_back, err, win, levels, stop);
    std::vector<double> dys;
    for (size_t i = 0; i < corners.size(); ++i) {
        if (!ok_there[i] || !ok_back[i]) continue;
        if (std::hypot(back[i].x - corners[i].x, back[i].y - corners[i].y) > 0.5) continue;
        const double dx = (corners[i].x - there[i].x) * to_full_resolution;
        const double dy = (there[i].y - corners[i].y) * to_full_resolution;
        ++m.count;
        m.positive += dx >= 1.0;
        m.negative += dx <= -1.0;
        dys.push_back(std::abs(dy));
    }
    m.median_abs_dy = quantile(std::move(dys), 0.5);
    return m;
}

std::string left_right_swapped(const StereoMatches &m) {
    const int signed_count = m.positive + m.negative;
    if (signed_count < kMinMatches || m.negative < 3 * m.positive) return "";
    return format("%.0f of %.0f stereo matches lie right of their left-image position (negative disparity)",
                  m.negative, signed_count);
}

std::string not_rectified(const StereoMatches &m) {
    // Rectified rows agree to a fraction of a pixel; the threshold leaves room for LK's noise.
    if (m.count < kMinMatches || m.median_abs_dy <= 1.5) return "";
    return format("matching features lie %.1f px apart vertically (median of %.0f; rectified rows agree within 1 px)",
                  m.median_abs_dy, m.count);
}

LidarAgreement lidar_agreement(const cv::Mat1b &left, const cv::Mat1b &right, const SparseLidar &lidar,
                               double scale, int threads) {
    LidarAgreement a;
    const int rad = 3, n = (2 * rad + 1) * (2 * rad + 1);
    const int W = left.cols, H = left.rows;
    const int max_d = W / 4;
    const size_t budget = 240;  // points examined, evenly spread over the list
    const size_t stride = std::max<size_t>(1, lidar.points.size() / budget);
    const int examined = static_cast<int>((lidar.points.size() + stride - 1) / stride);
    // Each examined point's residual (NaN: undecided), in parallel, then kept in the list's order.
    // Buffers allocated before the parallel region (its body cannot throw).
    std::vector<double> residual(static_cast<size_t>(examined), std::numeric_limits<double>::quiet_NaN());
    const int T = std::max(1, threads);
    std::vector<std::vector<double>> scores(static_cast<size_t>(T), std::vector<double>(std::max(max_d, 0) + 1));
#pragma omp parallel num_threads(T)
    {
        std::vector<double> &score = scores[static_cast<size_t>(omp_get_thread_num())];
#pragma omp for schedule(dynamic, 8)
        for (int j = 0; j < examined; ++j) {
            const LidarPoint &p = lidar.points[static_cast<size_t>(j) * stride];
            const int x = static_cast<int>(std::lround(p.x * scale)), y = static_cast<int>(std::lround(p.y * scale));
            const double d = p.disparity * scale;
            if (y < rad || y >= H - rad || x < rad || x >= W - rad || x - d < rad) continue;
            double s = 0, s2 = 0;
            for (int dy = -rad; dy <= rad; ++dy)
                for (int dx = -rad; dx <= rad; ++dx) {
                    const double v = left(y + dy, x + dx);
                    s += v;
                    s2 += v * v;
                }
            const double ml = s / n, sl = std::sqrt(std::max(0.0, s2 / n - ml * ml));
            if (sl < 6.0) continue;  // too little texture to judge
            const int hi = std::min(max_d, x - rad);
            std::fill(score.begin(), score.begin() + hi + 1, -1.0);
            int best = 0;
            for (int k = 0; k <= hi; ++k) {
                score[k] = zncc(left, right, x, x - k, y, rad, ml, sl);
                if (score[k] > score[best]) best = k;
            }
            if (score[best] < 0.7) continue;
            double rival = -1;
            for (int k = 0; k <= hi; ++k)
                if (std::abs(k - best) > 2) rival = std::max(rival, score[k]);
            if (rival > score[best] - 0.05) continue;  // ambiguous (repetitive texture)
            // Sub-pixel: the parabola through the best score and its neighbours.
            double sub = best;
            if (best > 0 && best < hi) {
                const double c0 = score[best - 1], c1 = score[best], c2 = score[best + 1];
                const double den = c0 - 2 * c1 + c2;
                if (den < 0) sub = best + 0.5 * (c0 - c2) / den;
            }
            residual[static_cast<size_t>(j)] = std::abs(sub - d) / scale;
        }
    }
    std::vector<double> residuals;
    for (const double r : residual)
        if (!std::isnan(r)) residuals.push_back(r);
    a.decided = static_cast<int>(residuals.size());
    a.residual_p75 = quantile(std::move(residuals), 0.75);
    return a;
}

std::string lidar_disagrees(const LidarAgreement &a) {
    // A calibrated rig leaves ~1.6 px (KITTI); a LiDAR tilted by 1 degree or moved by 0.3 m, 4 px.
    if (a.decided < kMinLidar || a.residual_p75 <= 2.8) return "";
    return format("a quarter of %.0f LiDAR points differ from the images' disparity by over %.1f px (a calibrated "
                  "rig: under 3; check the LiDAR-to-camera transform)",
                  a.decided, a.residual_p75);
}

StereoCheck check_stereo(const cv::Mat &left0, const cv::Mat &right0, const SparseLidar *lidar0, int threads) {
    StereoCheck c;
    const double scale = work_scale(left0.size());
    // Too small a frame for corners, a pyramid and patches (such frames are refused later on).
    if (left0.cols * scale < kMinSide || left0.rows * scale < kMinSide) return c;
    const cv::Mat1b left = work_gray(left0, scale), right = work_gray(right0, scale);
    c.matches = match_stereo_features(left, right, 1.0 / scale);
    c.swapped = left_right_swapped(c.matches);
    c.skewed = not_rectified(c.matches);
    if (c.swapped.empty() && c.skewed.empty() && lidar0 && !lidar0->points.empty()) {
        c.lidar = lidar_agreement(left, right, *lidar0, scale, threads);
        c.lidar_disagrees = lidar_disagrees(c.lidar);
    }
    return c;
}

Report assess(const Input &in, const StereoCheck *t0) {
    Report r;
    if (const std::string w = calibration_size_mismatch(in.calibration_size, in.left0.size()); !w.empty())
        r.add(CalibrationSizeMismatch, w);
    if (const std::string w = blank_frame(in); !w.empty()) {
        r.add(BlankFrame, w);
        return r;  // nothing else is measurable on a blank frame
    }
    const StereoCheck c = t0 ? *t0 : check_stereo(in.left0, in.right0, in.lidar0, in.threads);
    if (!c.swapped.empty()) r.add(LeftRightSwapped, c.swapped);
    if (!c.skewed.empty()) r.add(NotRectified, c.skewed);
    if (!c.lidar_disagrees.empty()) r.add(LidarDisagrees, c.lidar_disagrees);
    if (log::enabled(log::Level::Debug))
        log::write(log::Level::Debug,
                   "input quality: " + std::to_string(c.matches.count) + " stereo matches (" +
                       std::to_string(c.matches.positive) + " positive, " + std::to_string(c.matches.negative) +
                       " negative disparity), median |dy| " + format("%.2f px", c.matches.median_abs_dy) +
                       "; LiDAR residual p75 " + format("%.2f px", c.lidar.residual_p75) + " of " +
                       std::to_string(c.lidar.decided) + " points; " + r.summary());
    return r;
}

}  // namespace lidarflow::quality
