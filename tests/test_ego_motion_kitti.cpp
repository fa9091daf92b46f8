// SPDX-License-Identifier: MIT
// lf_get_ego_motion and lf_get_object_motion on the shared KITTI frames, against an ego-motion
// derived from the ground truth (KITTI gives no object map, so no static mask):
//  - every pixel with GT disparity at t0 (disp_occ_0), at t1 (disp_occ_1, in t0 pixels) and GT
//    flow (flow_occ) becomes a pair X0 = (x, y, d0), X1 = (x + u, y + v, d1) triangulated with
//    the calibration (fx, fy, cx, cy of P_rect_02, baseline from P_rect_03);
//  - the dominant rigid motion X1 = R X0 + t is fitted by RANSAC over 3-point sets (Kabsch),
//    a pair being an inlier when T X0 reprojects within 1 px of (x + u, y + v) and 0.5 px of
//    d1; then refitted by weighted least squares (weights 1 / z0^2, the inverse of the depth
//    variance of a disparity error) on the inliers, four rounds of inlier re-selection.
// The estimator runs through the C ABI (paper LiDAR protocol, default and realtime presets).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "core/camera.hpp"
#include "eval/kitti_eval.hpp"
#include "eval/kitti_runner.hpp"
#include "eval/metrics.hpp"
#include "lidarflow/lidarflow.h"
#include "test_support.hpp"

using namespace lidarflow;

namespace {

std::string g_root;

// Bounds on the estimator's ego-motion against the GT one, about 4x and 8x what the default and
// realtime presets reach (docs/ARCHITECTURE.md, "Ego-motion"). A zero motion misses by the whole
// 0.32 / 0.42 m of these frames, a flipped sign or an inverted transform by twice that.
constexpr double kTranslationBound = 0.05;  // [m] ||t - t_gt||
constexpr double kRotationBound = 0.2;      // [deg] angle of R R_gt^T
constexpr double kStaticMedianBound = 0.05; // [m] median |object motion| on the GT's static points

struct Pair {
    Eigen::Vector3d p0, p1;
    int x, y;  // t0 pixel
    double x1, y1, d1;
};

struct Rigid {
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

Eigen::Vector3d back_project(const StereoCamera &c, double x, double y, double d) {
    const double z = c.fx * c.baseline / d;
    return {(x - c.cx) * z / c.fx, (y - c.cy) * z / c.fy, z};
}

// Weighted Kabsch: the rotation and translation minimising sum w |R p0 + t - p1|^2.
Rigid fit(const std::vector<Pair> &pairs, const std::vector<int> &ids, bool weighted) {
    Eigen::Vector3d m0 = Eigen::Vector3d::Zero(), m1 = Eigen::Vector3d::Zero();
    double ws = 0;
    auto weight = [&](const Pair &p) { return weighted ? 1.0 / (p.p0.z() * p.p0.z()) : 1.0; };
    for (int i : ids) {
        const double w = weight(pairs[i]);
        m0 += w * pairs[i].p0, m1 += w * pairs[i].p1, ws += w;
    }
    m0 /= ws, m1 /= ws;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (int i : ids) H += weight(pairs[i]) * (pairs[i].p0 - m0) * (pairs[i].p1 - m1).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
    Rigid r;
    r.R = svd.matrixV() * D * svd.matrixU().transpose();
    r.t = m1 - r.R * m0;
    return r;
}

bool inlier(const StereoCamera &c, const Rigid &m, const Pair &p) {
    const Eigen::Vector3d q = m.R * p.p0 + m.t;
    if (q.z() < 0.5) return false;
    const double x = c.fx * q.x() / q.z() + c.cx, y = c.fy * q.y() / q.z() + c.cy, d = c.fx * c.baseline / q.z();
    return std::hypot(x - p.x1, y - p.y1) < 1.0 && std::fabs(d - p.d1) < 0.5;
}

struct GtEgo {
    Rigid motion;
    std::vector<Pair> pairs;
    std::vector<int> inliers;
};

GtEgo gt_ego_motion(const eval::GroundTruth &gt, const StereoCamera &c) {
    GtEgo g;
    for (int y = 0; y < gt.d0.rows; ++y)
        for (int x = 0; x < gt.d0.cols; ++x) {
            const float d0 = gt.d0(y, x), d1 = gt.d1(y, x);
            if (!(d0 > 1.0f) || !(d1 > 1.0f) || !gt.flow.valid(y, x)) continue;
            const double x1 = x + gt.flow.u(y, x), y1 = y + gt.flow.v(y, x);
            g.pairs.push_back({back_project(c, x, y, d0), back_project(c, x1, y1, d1), x, y, x1, y1, d1});
        }
    const int n = static_cast<int>(g.pairs.size());
    std::mt19937 rng(1);
    std::uniform_int_distribution<int> pick(0, n - 1);
    int best_count = -1;
    for (int h = 0; h < 500; ++h) {
        const Rigid m = fit(g.pairs, {pick(rng), pick(rng), pick(rng)}, false);
        int count = 0;
        for (int i = 0; i < n; i += 7) count += inlier(c, m, g.pairs[i]);
        if (count > best_count) best_count = count, g.motion = m;
    }
    for (int round = 0; round < 4; ++round) {
        g.inliers.clear();
        for (int i = 0; i < n; ++i)
            if (inlier(c, g.motion, g.pairs[i])) g.inliers.push_back(i);
        g.motion = fit(g.pairs, g.inliers, true);
    }
    g.inliers.clear();
    for (int i = 0; i < n; ++i)
        if (inlier(c, g.motion, g.pairs[i])) g.inliers.push_back(i);
    return g;
}

lf_image_t image_of(const cv::Mat &m) {
    return {m.data, static_cast<uint32_t>(m.cols), static_cast<uint32_t>(m.rows), static_cast<uint64_t>(m.step[0]),
            m.channels() == 1 ? LF_PIXEL_GRAY8 : LF_PIXEL_BGR8};
}

std::vector<float> lidar_entries(const SparseLidar &l) {
    std::vector<float> e;
    for (const LidarPoint &p : l.points) e.insert(e.end(), {float(p.x), float(p.y), p.disparity});
    return e;
}

struct Measured {
    double t_err, r_err_deg, static_median;
    double object_motion_ms;  // lf_get_object_motion on the whole frame
    unsigned inliers, candidates;
};

Measured run_frame(const char *preset, const std::string &id) {
    const eval::KittiFrame f = eval::load_kitti_frame(g_root, id, {});
    const eval::FrameGroundTruth gt = eval::load_ground_truth(g_root, id);
    const StereoCamera &cam = f.input.camera;
    const GtEgo g = gt_ego_motion(gt.occ, cam);
    const double share = double(g.inliers.size()) / g.pairs.size();
    std::printf("%s GT: %zu pairs, %.1f %% inliers, t = (%.3f %.3f %.3f) m\n", id.c_str(), g.pairs.size(),
                100 * share, g.motion.t.x(), g.motion.t.y(), g.motion.t.z());
    assert_true(share > 0.5);             // the static world dominates these frames
    assert_true(g.motion.t.norm() > 0.2); // the car drives: a zero motion must fail the bound

    lf_options_t *opt = nullptr;
    assert_int_equal(lf_options_create(&opt), LF_OK);
    assert_int_equal(lf_options_set_string(opt, "preset", preset), LF_OK);
    assert_int_equal(lf_options_set_int(opt, "threads", 2), LF_OK);
    lf_calibration_t cal;
    lf_calibration_init(&cal);
    cal.fx = cam.fx, cal.fy = cam.fy, cal.cx = cam.cx, cal.cy = cam.cy, cal.baseline = cam.baseline;
    lf_estimator_t *est = nullptr;
    assert_int_equal(lf_create(opt, &cal, &est), LF_OK);
    lf_options_destroy(opt);

    lf_ego_motion_t ego;
    lf_ego_motion_init(&ego);
    assert_int_equal(lf_get_ego_motion(est, &ego), LF_ERR_NOT_READY);
    const std::vector<float> l0 = lidar_entries(f.input.lidar0), l1 = lidar_entries(f.input.lidar1);
    const lf_lidar_t lidar0{LF_LIDAR_DISPARITY, static_cast<uint32_t>(l0.size() / 3), l0.data(), 0};
    const lf_lidar_t lidar1{LF_LIDAR_DISPARITY, static_cast<uint32_t>(l1.size() / 3), l1.data(), 0};
    const lf_image_t a0 = image_of(f.input.left0), b0 = image_of(f.input.right0);
    const lf_image_t a1 = image_of(f.input.left1), b1 = image_of(f.input.right1);
    assert_int_equal(lf_push_frame(est, 0, &a0, &b0, &lidar0), LF_OK);
    assert_int_equal(lf_get_ego_motion(est, &ego), LF_ERR_NOT_READY);
    assert_int_equal(lf_push_frame(est, 100000, &a1, &b1, &lidar1), LF_OK);
    assert_int_equal(lf_get_ego_motion(est, &ego), LF_OK);
    assert_int_equal(ego.state, LF_EGO_OK);

    Rigid m;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) m.R(i, j) = ego.transform[4 * i + j];
        m.t(i) = ego.transform[4 * i + 3];
    }
    assert_true(ego.transform[12] == 0 && ego.transform[13] == 0 && ego.transform[14] == 0 && ego.transform[15] == 1);
    assert_true((m.R.transpose() * m.R - Eigen::Matrix3d::Identity()).norm() < 1e-6 && m.R.determinant() > 0);
    Measured out;
    out.t_err = (m.t - g.motion.t).norm();
    const double c = std::clamp(((m.R * g.motion.R.transpose()).trace() - 1) / 2, -1.0, 1.0);
    out.r_err_deg = std::acos(c) * 180 / M_PI;
    out.inliers = ego.inliers, out.candidates = ego.candidates;

    const int w = f.input.left0.cols, h = f.input.left0.rows;
    cv::Mat3f motion(h, w);
    cv::Mat1b valid(h, w);
    lf_object_motion_buffers_t b;
    lf_object_motion_buffers_init(&b);
    b.width = w, b.height = h;
    b.motion = {motion.data, motion.step[0]};
    b.valid = {valid.data, valid.step[0]};
    const auto t_om = std::chrono::steady_clock::now();
    assert_int_equal(lf_get_object_motion(est, &b), LF_OK);
    out.object_motion_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_om).count();
    std::vector<double> mags;
    for (int i : g.inliers) {
        const Pair &p = g.pairs[i];
        if (!valid(p.y, p.x)) continue;
        const cv::Vec3f v = motion(p.y, p.x);
        mags.push_back(std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]));
    }
    assert_true(mags.size() > g.inliers.size() / 2);
    std::nth_element(mags.begin(), mags.begin() + mags.size() / 2, mags.end());
    out.static_median = mags[mags.size() / 2];
    lf_destroy(est);
    std::printf("%s %s: ego t = (%.3f %.3f %.3f) m, |dt| %.3f m, rotation error %.3f deg, %u of %u inliers, "
                "static object motion median %.3f m, lf_get_object_motion %.1f ms\n",
                id.c_str(), preset, m.t.x(), m.t.y(), m.t.z(), out.t_err, out.r_err_deg, out.inliers, out.candidates,
                out.static_median, out.object_motion_ms);
    return out;
}

void check_preset(const char *preset) {
    for (const std::string &id : test::kitti_ids()) {
        const Measured m = run_frame(preset, id);
        assert_true(m.t_err < kTranslationBound);
        assert_true(m.r_err_deg < kRotationBound);
        assert_true(m.inliers > 0 && m.inliers <= m.candidates);
        assert_true(m.static_median < kStaticMedianBound);
    }
}

void ego_default(void **) { check_preset("default"); }
void ego_realtime(void **) { check_preset("realtime"); }

}  // namespace

int main() {
    g_root = test::kitti_dir_or_skip("ego_motion_kitti");
    const struct CMUnitTest tests[] = {cmocka_unit_test(ego_realtime), cmocka_unit_test(ego_default)};
    return cmocka_run_group_tests_name("ego_motion_kitti", tests, nullptr, nullptr);
}
