// SPDX-License-Identifier: MIT
// The stream's motion prior (matching/motion_prior.hpp):
//  - on an exact scene flow (a static plane and a box that moves on its own while the camera
//    drives), the box's object motion is carried to its t1 pixels and nothing else is marked;
//    the next pair's prior predicts the box's flow exactly, and the way back inverts it;
//  - on the same scene, the static LiDAR points are carried to where they land at t1 with their
//    t1 disparity, the box's points and points past their age stay behind, and the next pair
//    takes a carried point only on a free pixel its stereo confirms;
//  - the carried motion, the next pair's prior and the way back are the same on any thread count;
//  - on a synthetic drive whose cars overtake and approach, `lidarflow sequence` with the prior
//    scores better than the same pairs without it (the pairs one by one).
// Runs the built binary ($LIDARFLOW_CLI, set by CTest).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/points3d.hpp"
#include "eval/metrics.hpp"
#include "io/kitti_png.hpp"
#include "io/result_formats.hpp"
#include "matching/motion_prior.hpp"
// cmocka 1.1.5's header lacks extern "C" and its fail() macro breaks <ios>: include it last.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;
namespace fs = std::filesystem;

namespace {

constexpr int W = 160, H = 96;
const StereoCamera kCam{200, 200, 80, 48, 0.5};
const double kT[3] = {0.05, 0.0, -1.0};         // the camera drives 1 m forward: points come 1 m closer
const double kObject[3] = {0.6, 0.0, -0.8};     // the box's own motion [m]
bool in_box(double x, double y) { return x >= 60 && x < 100 && y >= 30 && y < 70; }

// t0 point of pixel (x, y): the box at 8 m, the plane at 20 m.
double depth0(int x, int y) { return in_box(x, y) ? 8.0 : 20.0; }

void pixel_of(const double p[3], double &x, double &y) {
    x = kCam.fx * p[0] / p[2] + kCam.cx;
    y = kCam.fy * p[1] / p[2] + kCam.cy;
}

motion::EgoMotion ego() {
    motion::EgoMotion m;
    m.valid = m.calibrated = true;
    for (int i = 0; i < 3; ++i) m.t[i] = kT[i];
    m.camera = kCam;
    return m;
}

// The exact scene flow of the scene above, t0 -> t1.
SceneFlowField exact_field() {
    SceneFlowField f = SceneFlowField::zeros(W, H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const double z = depth0(x, y), d0 = kCam.disparity_from_depth(z);
            double p[3], x1, y1;
            back_project(kCam, x, y, d0, p);
            for (int i = 0; i < 3; ++i) p[i] += kT[i] + (in_box(x, y) ? kObject[i] : 0.0);
            pixel_of(p, x1, y1);
            f.u(y, x) = static_cast<float>(x1 - x);
            f.v(y, x) = static_cast<float>(y1 - y);
            f.d0(y, x) = static_cast<float>(d0);
            f.d1(y, x) = static_cast<float>(kCam.disparity_from_depth(p[2]));
            f.valid(y, x) = 1;
        }
    return f;
}

bool finite3(const cv::Vec3f &v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// The pixels `objects` marks, each asserted to hold (a, b, c) within 1e-3.
int marked_with(const cv::Mat3f &objects, double a, double b, double c) {
    int marked = 0;
    for (int y = 0; y < objects.rows; ++y)
        for (int x = 0; x < objects.cols; ++x)
            if (finite3(objects(y, x))) {
                ++marked;
                const double want[3] = {a, b, c};
                for (int i = 0; i < 3; ++i) assert_true(std::fabs(objects(y, x)[i] - want[i]) < 1e-3);
            }
    return marked;
}

void object_motion_is_carried_and_predicted(void **) {
    const SceneFlowField f = exact_field();
    const cv::Mat3f objects = matching::carry_object_motion(f, ego(), kCam);
    assert_int_equal(objects.rows, H);
    int marked = 0, wrong = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            if (!finite3(objects(y, x))) continue;
            ++marked;
            for (int i = 0; i < 3; ++i) wrong += std::fabs(objects(y, x)[i] - kObject[i]) > 1e-3;
        }
    // The box covers ~40x40 px at 8 m and more at its t1 depth of 6.2 m; the plane is never marked.
    std::printf("marked %d pixels, %d wrong components\n", marked, wrong);
    assert_true(marked > 1600);
    assert_int_equal(wrong, 0);

    // The next pair: the box's t1 disparity where it landed, the plane's elsewhere; its prior is
    // the plane's motion there, and the box keeps its object motion.
    DisparityMap d1(H, W, static_cast<float>(kCam.disparity_from_depth(19.0)));
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            if (finite3(objects(y, x))) d1(y, x) = static_cast<float>(kCam.disparity_from_depth(8.0 - 1.0 - 0.8));
    cv::Mat2f prior(H, W, cv::Vec2f(0, 0));
    matching::add_object_motion(ego(), d1, objects, prior);
    int checked = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            if (!finite3(objects(y, x))) {
                assert_true(prior(y, x) == cv::Vec2f(0, 0));  // untouched
                continue;
            }
            double p[3], x2, y2;
            back_project(kCam, x, y, d1(y, x), p);
            for (int i = 0; i < 3; ++i) p[i] += kT[i] + kObject[i];
            pixel_of(p, x2, y2);
            assert_true(std::fabs(prior(y, x)[0] - (x2 - x)) < 1e-3 && std::fabs(prior(y, x)[1] - (y2 - y)) < 1e-3);
            ++checked;
        }
    assert_int_equal(checked, marked);

    // The way back: -R^T o at the t1 pixels the forward flow reaches.
    cv::Mat2f flow(H, W);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) flow(y, x) = cv::Vec2f(f.u(y, x), f.v(y, x));
    const cv::Mat3f back = matching::reverse_object_motion(objects, flow, ego());
    int back_marked = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            if (finite3(back(y, x))) {
                ++back_marked;
                for (int i = 0; i < 3; ++i) assert_true(std::fabs(back(y, x)[i] + kObject[i]) < 1e-3);
            }
    assert_true(back_marked > 1000);

    // Without a calibrated background motion there is no prior, and nothing changes.
    motion::EgoMotion none;
    assert_true(matching::carry_object_motion(f, none, kCam).empty());
    const cv::Mat2f before(H, W, cv::Vec2f(1, 2));
    cv::Mat2f after = before.clone();
    matching::add_object_motion(none, d1, objects, after);
    assert_true(cv::norm(before, after, cv::NORM_INF) == 0);
}

// The same bits on any thread count (NaN included: the maps are compared as bytes).
bool same_bits(const cv::Mat &a, const cv::Mat &b) {
    return a.size() == b.size() && a.type() == b.type() && a.isContinuous() && b.isContinuous() &&
           std::equal(a.datastart, a.dataend, b.datastart);
}

void object_motion_is_the_same_on_any_thread_count(void **) {
    const SceneFlowField f = exact_field();
    const cv::Mat3f one = matching::carry_object_motion(f, ego(), kCam, 1, 1);
    assert_true(same_bits(one, matching::carry_object_motion(f, ego(), kCam, 1, 3)));
    assert_true(same_bits(matching::carry_object_motion(f, ego(), kCam, 2, 1),
                          matching::carry_object_motion(f, ego(), kCam, 2, 3)));
    DisparityMap d1(H, W, static_cast<float>(kCam.disparity_from_depth(7.0)));
    cv::Mat2f a(H, W, cv::Vec2f(0, 0)), b = a.clone();
    matching::add_object_motion(ego(), d1, one, a, 1);
    matching::add_object_motion(ego(), d1, one, b, 3);
    assert_true(same_bits(a, b));
    cv::Mat2f flow(H, W);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) flow(y, x) = cv::Vec2f(f.u(y, x), f.v(y, x));
    assert_true(same_bits(matching::reverse_object_motion(one, flow, ego(), 1),
                          matching::reverse_object_motion(one, flow, ego(), 3)));
}

// Frames in flight: carried two steps at constant velocity, the box lands where t0 + 2 (camera
// + object motion) projects, with its object motion; nothing else is marked.
void object_motion_is_carried_two_steps(void **) {
    const cv::Mat3f objects = matching::carry_object_motion(exact_field(), ego(), kCam, 2);
    double lo[2] = {1e9, 1e9}, hi[2] = {-1e9, -1e9};
    for (const double cx : {60.0, 99.0})
        for (const double cy : {30.0, 69.0}) {
            double p[3], x2, y2;
            back_project(kCam, cx, cy, kCam.disparity_from_depth(8.0), p);
            for (int i = 0; i < 3; ++i) p[i] += 2 * (kT[i] + kObject[i]);
            pixel_of(p, x2, y2);
            lo[0] = std::min(lo[0], x2), lo[1] = std::min(lo[1], y2);
            hi[0] = std::max(hi[0], x2), hi[1] = std::max(hi[1], y2);
        }
    int inside = 0, marked_inside = 0, marked_outside = 0, wrong = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const bool in = x > lo[0] + 2 && x < hi[0] - 2 && y > lo[1] + 2 && y < hi[1] - 2;
            const bool out = x < lo[0] - 2 || x > hi[0] + 2 || y < lo[1] - 2 || y > hi[1] + 2;
            const bool marked = finite3(objects(y, x));
            inside += in;
            marked_inside += in && marked;
            marked_outside += out && marked;
            if (marked)
                for (int i = 0; i < 3; ++i) wrong += std::fabs(objects(y, x)[i] - kObject[i]) > 1e-3;
        }
    std::printf("two steps: box at x %.1f..%.1f, y %.1f..%.1f; %d of %d inside marked, %d outside\n", lo[0], hi[0],
                lo[1], hi[1], marked_inside, inside, marked_outside);
    assert_true(inside > 2500);  // at 4.4 m the box is ~1.8x its t0 size
    assert_int_equal(marked_inside, inside);
    assert_int_equal(marked_outside, 0);
    assert_int_equal(wrong, 0);
}

// The camera turns (3 degrees of yaw a frame) while the box keeps its motion in the world: in
// the next frame's camera the box's object motion is turned by that rotation. The next pair's
// prior, the way back and the two-step carry use the turned motion.
void object_motion_turns_with_the_camera(void **) {
    const double a = 3.0 * CV_PI / 180.0;
    const double R[9] = {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)};
    motion::EgoMotion m = ego();
    for (int i = 0; i < 9; ++i) m.R[i] = R[i];
    const auto turn = [&](const double v[3], double out[3]) {
        for (int i = 0; i < 3; ++i) out[i] = R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2];
    };
    double turned[3];
    turn(kObject, turned);
    // The pair's exact field under the turning camera.
    SceneFlowField f = SceneFlowField::zeros(W, H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const double d0 = kCam.disparity_from_depth(depth0(x, y));
            double p[3], q[3], x1, y1;
            back_project(kCam, x, y, d0, p);
            turn(p, q);
            for (int i = 0; i < 3; ++i) q[i] += kT[i] + (in_box(x, y) ? kObject[i] : 0.0);
            pixel_of(q, x1, y1);
            f.u(y, x) = static_cast<float>(x1 - x);
            f.v(y, x) = static_cast<float>(y1 - y);
            f.d0(y, x) = static_cast<float>(d0);
            f.d1(y, x) = static_cast<float>(kCam.disparity_from_depth(q[2]));
            f.valid(y, x) = 1;
        }
    const cv::Mat3f objects = matching::carry_object_motion(f, m, kCam);
    DisparityMap d1(H, W, static_cast<float>(kCam.disparity_from_depth(19.0)));
    int marked = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            if (finite3(objects(y, x))) {
                ++marked;
                d1(y, x) = static_cast<float>(kCam.disparity_from_depth(6.2));
            }
    assert_true(marked > 1600);
    cv::Mat2f prior(H, W, cv::Vec2f(0, 0));
    matching::add_object_motion(m, d1, objects, prior);
    double worst = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            if (!finite3(objects(y, x))) continue;
            double p[3], q[3], x2, y2;
            back_project(kCam, x, y, d1(y, x), p);
            turn(p, q);
            for (int i = 0; i < 3; ++i) q[i] += kT[i] + turned[i];
            pixel_of(q, x2, y2);
            worst = std::max({worst, std::fabs(prior(y, x)[0] - (x2 - x)), std::fabs(prior(y, x)[1] - (y2 - y))});
        }
    std::printf("turning: %d pixels marked, worst prior error %.2g px\n", marked, worst);
    assert_true(worst < 1e-3);
    // The way back from this pair's object motion R o is -o.
    cv::Mat2f flow(H, W);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) flow(y, x) = cv::Vec2f(f.u(y, x), f.v(y, x));
    assert_true(marked_with(matching::reverse_object_motion(objects, flow, m), -kObject[0], -kObject[1], -kObject[2]) >
                1000);
    // Two steps: the motion the pair after next starts from is the turned one.
    assert_true(marked_with(matching::carry_object_motion(f, m, kCam, 2), turned[0], turned[1], turned[2]) > 1600);
}

// t0 points every 4 px over the scene, aged 0 except every fifth, which is 3 frames old.
void static_points_are_carried(void **) {
    const SceneFlowField f = exact_field();
    SparseLidar t0{W, H, {}};
    std::vector<uint8_t> age;
    for (int y = 2; y < H; y += 4)
        for (int x = 2; x < W; x += 4) {
            t0.points.push_back({x, y, f.d0(y, x)});
            age.push_back(t0.points.size() % 5 == 0 ? 3 : 0);
        }
    const matching::CarriedLidar c = matching::carry_static_points(t0, age, f, ego(), 3);
    assert_int_equal(c.points.points.size(), c.age.size());
    // Each carried point is a young plane point moved by the camera's motion, a frame older.
    size_t expected = 0;
    cv::Mat1f want(H, W, -1.0f);
    cv::Mat1b want_age(H, W, static_cast<uchar>(0));
    for (size_t i = 0; i < t0.points.size(); ++i) {
        const LidarPoint &p = t0.points[i];
        if (age[i] >= 3 || in_box(p.x, p.y)) continue;
        double q[3], x1, y1;
        back_project(kCam, p.x, p.y, p.disparity, q);
        for (int k = 0; k < 3; ++k) q[k] += kT[k];
        pixel_of(q, x1, y1);
        const int tx = static_cast<int>(std::lround(x1)), ty = static_cast<int>(std::lround(y1));
        if (tx < 0 || ty < 0 || tx >= W || ty >= H) continue;
        const float d = static_cast<float>(kCam.disparity_from_depth(q[2]));
        if (d <= want(ty, tx)) continue;
        expected += want(ty, tx) < 0;
        want(ty, tx) = d;
        want_age(ty, tx) = static_cast<uchar>(age[i] + 1);
    }
    std::printf("%zu of %zu points carried (%zu expected)\n", c.points.points.size(), t0.points.size(), expected);
    assert_true(expected > 300);
    assert_int_equal(c.points.points.size(), expected);
    for (size_t i = 0; i < c.points.points.size(); ++i) {
        const LidarPoint &p = c.points.points[i];
        assert_true(std::fabs(p.disparity - want(p.y, p.x)) < 1e-3f);
        assert_int_equal(c.age[i], want_age(p.y, p.x));
    }
    // Without a calibrated background motion, or with no earlier frame to keep, nothing is carried.
    assert_true(matching::carry_static_points(t0, age, f, motion::EgoMotion{}, 3).empty());
    assert_true(matching::carry_static_points(t0, age, f, ego(), 0).empty());

    // The next pair: its own point on the first carried pixel wins; the stereo sees a nearer
    // surface at the second and nothing at the third; the rest join, with their ages.
    const std::vector<LidarPoint> &cp = c.points.points;
    SparseLidar own{W, H, {{cp[0].x, cp[0].y, 9.0f}}};
    DisparityMap d = c.points.to_map();
    d(cp[1].y, cp[1].x) = cp[1].disparity + 5.0f;
    d(cp[2].y, cp[2].x) = kInvalidDisparity;
    std::vector<uint8_t> merged_age;
    const SparseLidar merged = matching::merge_carried(own, c, d, 2.0f, merged_age);
    assert_int_equal(merged.points.size(), cp.size() - 2);
    assert_int_equal(merged_age.size(), merged.points.size());
    assert_true(merged.points[0] == own.points[0]);
    assert_int_equal(merged_age[0], 0);
    for (size_t i = 1; i < merged.points.size(); ++i) {
        assert_true(merged.points[i] == cp[i + 2]);
        assert_int_equal(merged_age[i], c.age[i + 2]);
    }
}

std::string name(int k) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%010d", k);
    return buf;
}

double drive_sf(const fs::path &drive, const fs::path &out, int first, int last) {
    std::vector<eval::FrameScore> scores;
    for (int k = first; k < last; ++k) {
        const std::string id = name(k);
        eval::FrameGroundTruth gt;
        gt.occ.d0 = io::read_disparity_png((drive / "gt/disp_occ_0" / (id + ".png")).string());
        gt.occ.d1 = io::read_disparity_png((drive / "gt/disp_occ_1" / (id + ".png")).string());
        gt.occ.flow = io::read_flow_png((drive / "gt/flow_occ" / (id + ".png")).string());
        eval::Estimate est;
        est.d0 = io::read_disparity_file((out / "disp_0" / (id + ".npy")).string());
        est.d1 = io::read_disparity_file((out / "disp_1" / (id + ".npy")).string());
        est.flow = io::read_flow_file((out / "flow" / (id + ".npy")).string());
        scores.push_back(eval::evaluate_frame(gt, est, eval::EvalOptions{}, nullptr, id));
    }
    return eval::summarize(scores).pooled.dense.occ.sf.outlier_pct();
}

void stream_beats_pairs_on_a_drive(void **) {
    const fs::path dir = test::scratch_dir("stream_prior"), drive = dir / "drive";
    // Frames 2..6 of seed 1: a car overtakes and one approaches (their flow grows to ~60 px).
    test::CliRun r = test::run_cli("synth --drive " + test::quoted(drive) + " --frames 7 --quiet");
    assert_int_equal(r.code, 0);
    double sf[2];
    for (int prior = 0; prior < 2; ++prior) {
        const fs::path out = dir / ("out" + std::to_string(prior));
        r = test::run_cli("sequence --drive " + test::quoted(drive) + " --out " + test::quoted(out) +
                          " --frames 2:6 --format npy --threads 2 --quiet --preset realtime --option matching.stream_prior=" +
                          std::to_string(prior));
        if (r.code != 0) std::printf("%s", r.output.c_str());
        assert_int_equal(r.code, 0);
        sf[prior] = drive_sf(drive, out, 2, 6);
    }
    std::printf("SF outliers (occ, pooled, frames 2..6): pairs one by one %.2f %%, stream prior %.2f %%\n", sf[0], sf[1]);
    assert_true(sf[1] < sf[0] - 1.0);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(object_motion_is_carried_and_predicted),
        cmocka_unit_test(object_motion_is_the_same_on_any_thread_count),
        cmocka_unit_test(object_motion_is_carried_two_steps),
        cmocka_unit_test(object_motion_turns_with_the_camera),
        cmocka_unit_test(static_points_are_carried),
        cmocka_unit_test(stream_beats_pairs_on_a_drive),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
