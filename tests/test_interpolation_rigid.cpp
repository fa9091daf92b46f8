// SPDX-License-Identifier: MIT
// Stage 4 with a known camera: the rigid ego-motion fit (fit_rigid_ego_motion) recovers an
// exact rigid motion from clean and from outlier-ridden matches and refuses without a camera or
// support; the interpolator uses it when run() gets a valid camera; occlusion reasoning gives
// matches hidden at t1 (d1 matched on a near object) the background's d1, and matches that
// its flow shows static too, unless they may move along the optical axis; t1 LiDAR points moved
// back to t0 measure d0 unless the matches where they land contradict them; new options are
// validated; the vectorised prediction of many points equals the one-point prediction bit for bit.
#include "test_support.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "core/error.hpp"
#include "motion/ego_motion.hpp"
#include "interpolation/interpolator.hpp"
#include "interpolation_scene.hpp"

using namespace lidarflow;
using test::expect_error;
using test::max_errors;

namespace {

StereoCamera kitti_camera() {
    StereoCamera c;
    c.fx = c.fy = 720;
    c.cx = 610;
    c.cy = 175;
    c.baseline = 0.54;
    return c;
}

// The true motion as an EgoMotion (exact rotation, not a linearisation): a car turning while
// driving forward.
motion::EgoMotion true_motion(const StereoCamera &cam) {
    motion::EgoMotion m;
    m.valid = m.calibrated = true;
    m.camera = cam;
    const double w[3] = {0.004, -0.015, 0.002};
    const double th = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    const double k[3] = {w[0] / th, w[1] / th, w[2] / th};
    const double K[9] = {0, -k[2], k[1], k[2], 0, -k[0], -k[1], k[0], 0};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double k2 = 0;
            for (int l = 0; l < 3; ++l) k2 += K[i * 3 + l] * K[l * 3 + j];
            m.R[i * 3 + j] = (i == j) + std::sin(th) * K[i * 3 + j] + (1 - std::cos(th)) * k2;
        }
    m.t[0] = 0.06, m.t[1] = -0.02, m.t[2] = -1.1;
    return m;
}

using Points = test::MotionSamples;

Points make_points(const motion::EgoMotion &truth, int n, uint64_t seed) {
    test::TestRng rng(seed);
    Points p;
    for (int i = 0; i < n; ++i) {
        const float x = static_cast<float>(1242 * rng.uniform()), y = static_cast<float>(375 * rng.uniform());
        const float d0 = static_cast<float>(4 + 70 * rng.uniform());  // 5.5 .. 97 m
        float d1, u, v;
        truth.predict(x, y, d0, d1, u, v);
        p.x.push_back(x), p.y.push_back(y), p.d0.push_back(d0), p.d1.push_back(d1), p.u.push_back(u), p.v.push_back(v);
    }
    return p;
}

void rigid_fit_exact(void **) {
    const StereoCamera cam = kitti_camera();
    const motion::EgoMotion truth = true_motion(cam);
    const Points fit = make_points(truth, 2000, 1), held = make_points(truth, 500, 2);
    const motion::EgoMotion m = motion::fit_rigid_ego_motion(fit.x, fit.y, fit.d0, fit.d1, fit.u, fit.v, {}, cam);
    assert_true(m.valid && m.calibrated);
    assert_int_equal(m.inliers, 2000);
    double e_d1, e_fl;
    max_errors(m, held, e_d1, e_fl);
    std::printf("rigid fit, exact matches: max error d1 %.4f px, flow %.4f px; t %.3f %.3f %.3f m\n", e_d1, e_fl,
                m.t[0], m.t[1], m.t[2]);
    assert_true(e_d1 < 0.01 && e_fl < 0.01);
    for (int k = 0; k < 3; ++k) assert_true(std::fabs(m.t[k] - truth.t[k]) < 1e-3);
    for (int k = 0; k < 9; ++k) assert_true(std::fabs(m.R[k] - truth.R[k]) < 1e-5);
    // The inverse motion takes every point back to where it was; a point the motion puts behind
    // the camera is reported; only rigid models have an inverse.
    const motion::EgoMotion back = truth.inverse();
    for (size_t i = 0; i < held.x.size(); ++i) {
        float d0, u, v;
        assert_true(back.predict(held.x[i] + held.u[i], held.y[i] + held.v[i], held.d1[i], d0, u, v));
        assert_true(std::fabs(d0 - held.d0[i]) < 1e-3 && std::fabs(held.u[i] + u) < 1e-3 && std::fabs(held.v[i] + v) < 1e-3);
    }
    motion::EgoMotion away = truth;
    away.t[2] = -100;  // 100 m forward: a point 50 m ahead ends up behind the camera
    float d1, u, v;
    assert_false(away.predict(610, 175, 720 * 0.54 / 50, d1, u, v));
    assert_false(motion::EgoMotion{}.inverse().valid);
}

// predict_many gives predict()'s floats bit for bit: a rigid motion (its vector loop), one that
// puts points behind the camera, no motion, and an odd count (the loop's tail).
void predict_many_equals_predict(void **) {
    const StereoCamera cam = kitti_camera();
    motion::EgoMotion away = true_motion(cam);
    away.t[2] = -100;
    test::TestRng rng(5);
    std::vector<float> x(1001), y(x.size()), d0(x.size());
    for (size_t i = 0; i < x.size(); ++i) {
        x[i] = static_cast<float>(1300 * rng.uniform() - 30), y[i] = static_cast<float>(400 * rng.uniform() - 10);
        d0[i] = i % 50 == 0 ? -1.0f : static_cast<float>(120 * rng.uniform());  // negatives count as 0
    }
    for (const motion::EgoMotion &m : {true_motion(cam), away, motion::EgoMotion{}}) {
        std::vector<float> d1(x.size()), u(x.size()), v(x.size());
        m.predict_many(x.data(), y.data(), d0.data(), static_cast<int>(x.size()), d1.data(), u.data(), v.data());
        for (size_t i = 0; i < x.size(); ++i) {
            float e1, eu, ev;
            m.predict(x[i], y[i], d0[i], e1, eu, ev);
            assert_true(std::memcmp(&e1, &d1[i], 4) == 0 && std::memcmp(&eu, &u[i], 4) == 0 &&
                        std::memcmp(&ev, &v[i], 4) == 0);
        }
    }
}

// n matches, a third of them wrong: the fit finds the rest, predicts held-out points within
// the noise and is the same on every run and thread count.
void robust_and_deterministic(int n, uint64_t seed) {
    const StereoCamera cam = kitti_camera();
    const motion::EgoMotion truth = true_motion(cam);
    Points fit = make_points(truth, n, seed);
    const Points held = make_points(truth, 500, seed + 1);
    test::TestRng rng(seed + 2);
    int bad = 0;
    for (size_t i = 0; i < fit.x.size(); ++i) {
        if (rng.uniform() >= 0.35) continue;  // independent movers / mismatches
        auto off = [&] { return static_cast<float>((rng.uniform() < 0.5 ? -1 : 1) * (3 + 20 * rng.uniform())); };
        fit.u[i] += off();
        fit.v[i] += off();
        fit.d1[i] = std::max(1.0f, fit.d1[i] + off());
        ++bad;
    }
    // Small matching noise on everything.
    for (size_t i = 0; i < fit.x.size(); ++i) {
        fit.u[i] += static_cast<float>(0.4 * (rng.uniform() - 0.5));
        fit.d1[i] += static_cast<float>(0.2 * (rng.uniform() - 0.5));
    }
    const motion::EgoMotion m = motion::fit_rigid_ego_motion(fit.x, fit.y, fit.d0, fit.d1, fit.u, fit.v, {}, cam);
    assert_true(m.valid);
    const int good = static_cast<int>(fit.x.size()) - bad;
    double e_d1, e_fl;
    max_errors(m, held, e_d1, e_fl);
    std::printf("rigid fit, %d of %zu outliers: %d inliers, max error d1 %.3f px, flow %.3f px\n", bad, fit.x.size(),
                m.inliers, e_d1, e_fl);
    assert_true(m.inliers >= good - 20 && m.inliers <= good + bad / 20);
    assert_true(e_d1 < 0.1 && e_fl < 0.2);
    const motion::EgoMotion again = motion::fit_rigid_ego_motion(fit.x, fit.y, fit.d0, fit.d1, fit.u, fit.v, {}, cam);
    assert_int_equal(again.inliers, m.inliers);
    for (int k = 0; k < 9; ++k) assert_true(again.R[k] == m.R[k]);
    for (int k = 0; k < 3; ++k) assert_true(again.t[k] == m.t[k]);
    // The hypotheses are scored and the refits summed in parallel: the same model, bit for bit,
    // on any thread count.
    for (int threads : {2, 3, 7}) {
        motion::EgoMotionOptions o;
        o.threads = threads;
        const motion::EgoMotion par = motion::fit_rigid_ego_motion(fit.x, fit.y, fit.d0, fit.d1, fit.u, fit.v, o, cam);
        assert_int_equal(par.inliers, m.inliers);
        for (int k = 0; k < 9; ++k) assert_true(par.R[k] == m.R[k]);
        for (int k = 0; k < 3; ++k) assert_true(par.t[k] == m.t[k]);
    }
}

void rigid_fit_robust_and_deterministic(void **) {
    robust_and_deterministic(7000, 3);  // the refits sum several blocks of points
}

// A dense scan's count: the refits sum every second inlier (at most 16384), the inliers are
// still counted over all matches.
void rigid_fit_of_a_dense_scan(void **) { robust_and_deterministic(40000, 13); }

void rigid_fit_refuses(void **) {
    const StereoCamera cam = kitti_camera();
    const motion::EgoMotion truth = true_motion(cam);
    const Points p = make_points(truth, 500, 6);
    // No camera: nothing to triangulate with.
    assert_false(motion::fit_rigid_ego_motion(p.x, p.y, p.d0, p.d1, p.u, p.v, {}, StereoCamera{}).valid);
    // Too few matches.
    const Points few = make_points(truth, 20, 7);
    assert_false(motion::fit_rigid_ego_motion(few.x, few.y, few.d0, few.d1, few.u, few.v, {}, cam).valid);
    // Mismatched array lengths are refused, not read out of bounds.
    std::vector<float> shorter(p.u.begin(), p.u.end() - 1);
    assert_false(motion::fit_rigid_ego_motion(p.x, p.y, p.d0, p.d1, shorter, p.v, {}, cam).valid);
    // Pure noise has no dominant motion.
    test::TestRng rng(8);
    Points noise = p;
    for (size_t i = 0; i < noise.x.size(); ++i) {
        noise.u[i] = static_cast<float>(80 * rng.uniform() - 40);
        noise.v[i] = static_cast<float>(80 * rng.uniform() - 40);
        noise.d1[i] = static_cast<float>(1 + 100 * rng.uniform());
    }
    assert_false(motion::fit_rigid_ego_motion(noise.x, noise.y, noise.d0, noise.d1, noise.u, noise.v, {}, cam).valid);
}

// The rig of the street scenes below (320x160) and its motion: 0.5 m straight ahead.
StereoCamera street_camera() {
    StereoCamera c;
    c.fx = c.fy = 200;
    c.cx = 160, c.cy = 80, c.baseline = 0.5;
    return c;
}

motion::EgoMotion driving_forward(const StereoCamera &cam) {
    motion::EgoMotion ego;
    ego.valid = ego.calibrated = true;
    ego.camera = cam;
    ego.t[2] = -0.5;
    return ego;
}

// What every street scene holds: the reference image (the wall's colour until the scene paints
// its objects), the exact field, the matches the interpolator gets, and the rig.
struct StreetScene {
    cv::Mat image;
    SceneFlowField truth, matches;
    StereoCamera cam;
};

// A plain 320x160 wall image, an all-valid zero truth for the scene to fill, the street rig;
// returns the camera's motion.
motion::EgoMotion start_street(StreetScene &c) {
    const int w = 320, h = 160;
    c.cam = street_camera();
    c.image = cv::Mat(h, w, CV_8UC3, cv::Scalar(170, 150, 120));
    c.truth = SceneFlowField::zeros(w, h);
    c.truth.valid.setTo(1);
    return driving_forward(c.cam);
}

// The exact field at a random `rate` of the pixels `where` admits (the generator is drawn only
// there, in row order), as matches.
template <class Where>
SceneFlowField sample_matches(const SceneFlowField &truth, double rate, uint64_t seed, Where where) {
    SceneFlowField m = SceneFlowField::zeros(truth.width(), truth.height());
    test::TestRng rng(seed);
    for (int y = 0; y < m.height(); ++y)
        for (int x = 0; x < m.width(); ++x) {
            if (!where(x, y) || rng.uniform() >= rate) continue;
            m.u(y, x) = truth.u(y, x), m.v(y, x) = truth.v(y, x);
            m.d0(y, x) = truth.d0(y, x), m.d1(y, x) = truth.d1(y, x);
            m.valid(y, x) = 1;
        }
    return m;
}

bool everywhere(int, int) { return true; }

// Mean |est - truth| over a rectangle.
double mean_error(const cv::Mat1f &est, const cv::Mat1f &truth, const cv::Rect &r) {
    return cv::norm(est(r), truth(r), cv::NORM_L1) / r.area();
}

// A static street front: a wall at 20 m and, before it, a post at 5 m, seen by a camera that
// drives forward. The wall just left of the post is hidden by it in the right view at t1, so
// the stereo matcher found the post's d1 there (what a real matcher does).
struct OcclusionCase : StreetScene {
    cv::Mat1b hidden;  // wall pixels whose d1 match is the post's
};

OcclusionCase occlusion_case() {
    OcclusionCase c;
    const motion::EgoMotion ego = start_street(c);
    const int w = c.image.cols, h = c.image.rows;
    const cv::Rect post(150, 30, 30, 110);
    c.image(post).setTo(cv::Scalar(30, 40, 200));
    cv::Mat1f right_post(h, w, -1.0f);  // post's d1 where the post lands in the right view at t1
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float d0 = post.contains({x, y}) ? 20.0f : 5.0f;
            float d1, u, v;
            ego.predict(static_cast<float>(x), static_cast<float>(y), d0, d1, u, v);
            c.truth.d0(y, x) = d0, c.truth.d1(y, x) = d1, c.truth.u(y, x) = u, c.truth.v(y, x) = v;
            if (!post.contains({x, y})) continue;
            const int rx = static_cast<int>(std::lround(x + u - d1)), ry = static_cast<int>(std::lround(y + v));
            if (rx >= 0 && rx < w && ry >= 0 && ry < h) right_post(ry, rx) = d1;
        }
    c.hidden = cv::Mat1b(h, w, uint8_t{0});
    c.matches = sample_matches(c.truth, 0.12, 3, everywhere);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (post.contains({x, y})) continue;
            const int rx = static_cast<int>(std::lround(x + c.truth.u(y, x) - c.truth.d1(y, x)));
            const int ry = static_cast<int>(std::lround(y + c.truth.v(y, x)));
            if (rx < 0 || rx >= w || ry < 0 || ry >= h || right_post(ry, rx) < 0) continue;
            c.hidden(y, x) = 255;
            if (c.matches.valid(y, x)) c.matches.d1(y, x) = right_post(ry, rx);
        }
    return c;
}

double mean_d1_error(const SceneFlowField &est, const OcclusionCase &c) {
    double sum = 0;
    int n = 0;
    for (int y = 0; y < c.hidden.rows; ++y)
        for (int x = 0; x < c.hidden.cols; ++x)
            if (c.hidden(y, x)) sum += std::fabs(est.d1(y, x) - c.truth.d1(y, x)), ++n;
    return n ? sum / n : 0.0;
}

void occlusion_reasoning_fixes_hidden_d1(void **) {
    const OcclusionCase c = occlusion_case();
    assert_true(cv::countNonZero(c.hidden) > 500);
    interpolation::InterpolationOptions o;
    // The hidden band's wrong d1 must dominate its superpixels' neighbourhoods: with the default
    // 256 neighbours the visible matches around it already fix it (0.16 px off and on).
    o.num_neighbors = 64;
    // The hidden wall is static by its flow, so the static-d1 rule alone would fix it too.
    o.static_d1_from_background = false;
    o.occlusion_reasoning = false;
    const interpolation::InterpolationResult off = interpolation::RobustInterpolator(o).run(c.matches, {}, c.image, {}, c.cam);
    o.occlusion_reasoning = true;
    const interpolation::InterpolationResult on = interpolation::RobustInterpolator(o).run(c.matches, {}, c.image, {}, c.cam);
    const double e_off = mean_d1_error(off.dense, c), e_on = mean_d1_error(on.dense, c);
    std::printf("hidden band (%d px): %d matches released; d1 error off %.2f px, on %.2f px\n",
                cv::countNonZero(c.hidden), on.occluded_seeds, e_off, e_on);
    assert_true(on.ego.valid && on.ego.calibrated);
    assert_int_equal(off.occluded_seeds, 0);
    assert_true(on.occluded_seeds > 30);
    assert_true(e_off > 3.0);
    assert_true(e_on < 0.5);
    // Elsewhere (all visible) nothing gets worse: the whole field stays near-exact.
    const test::OutlierRates r = test::outlier_rates(on.dense, c.truth);
    assert_true(r.sf < 1.0);
    // Without the camera the calibration-free model is used and the run still succeeds.
    const interpolation::InterpolationResult nocam = interpolation::RobustInterpolator(o).run(c.matches, {}, c.image);
    assert_false(nocam.ego.calibrated);
}

// A wall at 20 m seen by a camera driving forward, with a patch of matches whose d1 is 3 px
// off (a coherent t1 stereo mistake, flow right), and a car ahead, around the principal point,
// that keeps its distance: its flow is within the static tolerance of the background's, but
// its d1 is not the background's. The rule must fix the patch and leave the car alone; without
// the discrimination guard it paints the car with the background's d1.
struct StaticCase : StreetScene {
    cv::Rect patch, car;
};

StaticCase static_case() {
    StaticCase c;
    const motion::EgoMotion ego = start_street(c);
    const int w = c.image.cols, h = c.image.rows;
    c.patch = cv::Rect(20, 50, 48, 48);
    c.car = cv::Rect(150, 70, 21, 21);  // 5 m ahead, within ~14 px of the principal point
    c.image(c.car).setTo(cv::Scalar(30, 40, 200));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float d1, u, v;
            if (c.car.contains({x, y})) {
                c.truth.d0(y, x) = c.truth.d1(y, x) = 20.0f;  // same speed as the camera
            } else {
                ego.predict(static_cast<float>(x), static_cast<float>(y), 5.0f, d1, u, v);
                c.truth.d0(y, x) = 5.0f, c.truth.d1(y, x) = d1, c.truth.u(y, x) = u, c.truth.v(y, x) = v;
            }
        }
    c.matches = sample_matches(c.truth, 0.15, 5, everywhere);
    for (int y = c.patch.y; y < c.patch.br().y; ++y)
        for (int x = c.patch.x; x < c.patch.br().x; ++x)
            if (c.matches.valid(y, x)) c.matches.d1(y, x) += 3.0f;  // the coherent t1 stereo mistake
    return c;
}

void static_matches_take_background_d1(void **) {
    const StaticCase c = static_case();
    interpolation::InterpolationOptions o;
    o.num_neighbors = 64;  // the patch's wrong d1 must dominate its superpixels' neighbourhoods
    auto run = [&](bool rule, float discrimination) {
        o.static_d1_from_background = rule;
        o.static_d1_discrimination = discrimination;
        return interpolation::RobustInterpolator(o).run(c.matches, {}, c.image, {}, c.cam);
    };
    const interpolation::InterpolationResult off = run(false, 2.0f), on = run(true, 2.0f), unguarded = run(true, 0.0f);
    std::printf("static d1: car error off %.2f; patch error off %.2f / on %.2f px (%d matches released); car error on %.2f, "
                "without the guard %.2f px\n",
                mean_error(off.dense.d1, c.truth.d1, c.car), mean_error(off.dense.d1, c.truth.d1, c.patch), mean_error(on.dense.d1, c.truth.d1, c.patch),
                on.static_d1_seeds, mean_error(on.dense.d1, c.truth.d1, c.car),
                mean_error(unguarded.dense.d1, c.truth.d1, c.car));
    assert_true(on.ego.valid && on.ego.calibrated);
    assert_int_equal(off.static_d1_seeds, 0);
    assert_true(mean_error(off.dense.d1, c.truth.d1, c.patch) > 2.0);
    assert_true(mean_error(on.dense.d1, c.truth.d1, c.patch) < 0.5);
    // The car is left as it was without the rule (its edge pixels share superpixels with the
    // wall either way); unguarded, the rule moves it onto the background's d1.
    const double car_off = mean_error(off.dense.d1, c.truth.d1, c.car);
    assert_true(std::fabs(mean_error(on.dense.d1, c.truth.d1, c.car) - car_off) < 0.05);
    assert_true(mean_error(unguarded.dense.d1, c.truth.d1, c.car) > car_off + 1.0);
    // Without the camera there is no rigid model, and nothing is released.
    o.static_d1_from_background = true;
    assert_int_equal(interpolation::RobustInterpolator(o).run(c.matches, {}, c.image).static_d1_seeds, 0);
}

// A wall at 20 m, a near block at 8.3 m without a single match (a hole), and a box 10 m away
// that moves 1 m sideways on its own. The t1 scan has points on the block and on the box; the
// t0 scan has only a few on the wall. Moved back by the background motion, the block's t1
// points measure its d0; the box's land 20 px beside it, on the box's own moving matches or on
// the wall's (another depth), and must be dropped.
struct Lidar1Case : StreetScene {
    SparseLidar lidar0, lidar1, lidar1_box;  // lidar1: the block's and the box's points
    cv::Rect block, box;
    int block_points = 0;
};

Lidar1Case lidar1_case() {
    Lidar1Case c;
    const motion::EgoMotion ego = start_street(c);
    const int w = c.image.cols, h = c.image.rows;
    motion::EgoMotion box_motion = ego;
    box_motion.t[0] = 1.0;  // its own 1 m to the side, on top of the camera's motion
    c.block = cv::Rect(20, 40, 80, 80);
    c.box = cv::Rect(200, 50, 50, 50);
    c.image(c.block).setTo(cv::Scalar(60, 160, 60));
    c.image(c.box).setTo(cv::Scalar(30, 40, 200));
    c.lidar0 = {w, h, {}};
    c.lidar1 = {w, h, {}};
    c.lidar1_box = {w, h, {}};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool in_block = c.block.contains({x, y}), in_box = c.box.contains({x, y});
            const float d0 = in_block ? 12.0f : in_box ? 10.0f : 5.0f;
            float d1, u, v;
            (in_box ? box_motion : ego).predict(static_cast<float>(x), static_cast<float>(y), d0, d1, u, v);
            c.truth.d0(y, x) = d0, c.truth.d1(y, x) = d1, c.truth.u(y, x) = u, c.truth.v(y, x) = v;
            if (x % 8 != 4 || y % 8 != 4) continue;
            if (!in_block && !in_box) {
                if (x % 64 == 4 && y % 64 == 4) c.lidar0.points.push_back({x, y, d0});
                continue;
            }
            const int tx = static_cast<int>(std::lround(x + u)), ty = static_cast<int>(std::lround(y + v));
            if (tx < 0 || ty < 0 || tx >= w || ty >= h) continue;
            c.lidar1.points.push_back({tx, ty, d1});
            if (in_box) c.lidar1_box.points.push_back({tx, ty, d1});
            c.block_points += in_block;
        }
    // The block is a hole: not a single match on it.
    c.matches = sample_matches(c.truth, 0.15, 9, [&](int x, int y) { return !c.block.contains({x, y}); });
    return c;
}

void lidar1_points_measure_static_holes(void **) {
    const Lidar1Case c = lidar1_case();
    assert_true(c.block_points > 50 && c.lidar1_box.points.size() > 20);
    interpolation::InterpolationOptions o;
    auto run = [&](bool rule, int radius, const SparseLidar &lidar1) {
        o.lidar1_from_background = rule;
        o.lidar1_check_radius = radius;
        return interpolation::RobustInterpolator(o).run(c.matches, c.lidar0, c.image, {}, c.cam, lidar1);
    };
    const interpolation::InterpolationResult off = run(false, 10, c.lidar1), on = run(true, 10, c.lidar1);
    const interpolation::InterpolationResult box = run(true, 10, c.lidar1_box), box_unchecked = run(true, 0, c.lidar1_box);
    // Block points within the check radius of its edge see the wall's matches, another depth,
    // in the majority, and are dropped too: the block's inside is measured.
    const cv::Rect inside(c.block.x + 10, c.block.y + 10, c.block.width - 20, c.block.height - 20);
    const double off_err = mean_error(off.dense.d0, c.truth.d0, c.block), on_err = mean_error(on.dense.d0, c.truth.d0, c.block);
    std::printf("t1 LiDAR: block d0 error off %.2f / on %.2f px (inside %.2f); %d of %zu points used (%d on the "
                "block); of the moving box's %zu points %d used, %d without the check\n",
                off_err, on_err, mean_error(on.dense.d0, c.truth.d0, inside), on.lidar1_points, c.lidar1.points.size(),
                c.block_points, c.lidar1_box.points.size(), box.lidar1_points, box_unchecked.lidar1_points);
    assert_true(on.ego.valid && on.ego.calibrated);
    assert_int_equal(off.lidar1_points, 0);
    assert_true(off_err > 3.0);
    assert_true(on_err < off_err / 3);
    assert_true(mean_error(on.dense.d0, c.truth.d0, inside) < 0.5);
    assert_true(on.lidar1_points > c.block_points / 2);
    assert_int_equal(box.lidar1_points, 0);
    assert_true(box_unchecked.lidar1_points > static_cast<int>(c.lidar1_box.points.size()) / 2);
    // Without the camera there is no rigid model to move the points back.
    o.lidar1_check_radius = 10;
    assert_int_equal(interpolation::RobustInterpolator(o).run(c.matches, c.lidar0, c.image, {}, {}, c.lidar1).lidar1_points, 0);
    // A t1 scan of another size is refused like a t0 one.
    const SparseLidar wrong{c.lidar1.width / 2, c.lidar1.height, c.lidar1.points};
    expect_error([&] { interpolation::RobustInterpolator(o).run(c.matches, c.lidar0, c.image, {}, c.cam, wrong); },
                 ErrorCode::SizeMismatch);
}

void rejects_bad_rigid_options(void **) {
    using O = interpolation::InterpolationOptions;
    auto bad = [](void (*edit)(O &)) {
        O o;
        edit(o);
        expect_error([&] { interpolation::RobustInterpolator ri(o); }, ErrorCode::InvalidArgument);
    };
    bad([](O &o) { o.background_preference = 0; });
    bad([](O &o) { o.background_preference = 1.5f; });
    bad([](O &o) { o.background_preference = std::nanf(""); });
    bad([](O &o) { o.occlusion_margin = 0; });
    bad([](O &o) { o.occlusion_margin = std::nanf(""); });
    bad([](O &o) { o.static_flow_tolerance = 0; });
    bad([](O &o) { o.static_flow_tolerance = std::nanf(""); });
    bad([](O &o) { o.static_d1_discrimination = -1; });
    bad([](O &o) { o.static_d1_discrimination = INFINITY; });
    bad([](O &o) { o.lidar1_check_radius = -1; });
    bad([](O &o) { o.lidar1_relative_tolerance = 0; });
    bad([](O &o) { o.lidar1_relative_tolerance = std::nanf(""); });
}

}  // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(rigid_fit_exact),
        cmocka_unit_test(predict_many_equals_predict),
        cmocka_unit_test(rigid_fit_robust_and_deterministic),
        cmocka_unit_test(rigid_fit_of_a_dense_scan),
        cmocka_unit_test(rigid_fit_refuses),
        cmocka_unit_test(occlusion_reasoning_fixes_hidden_d1),
        cmocka_unit_test(static_matches_take_background_d1),
        cmocka_unit_test(lidar1_points_measure_static_holes),
        cmocka_unit_test(rejects_bad_rigid_options),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
