// SPDX-License-Identifier: MIT
// Golden test of the complete estimator on the two shared KITTI 2015 frames (paper LiDAR
// protocol, the `paper` preset (the paper's design, also `default`); and the real Velodyne scan): the final dense scene flow must stay at
// the accuracy recorded, within a tolerance, and meet the targets on the mean.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "eval/kitti_eval.hpp"
#include "eval/kitti_runner.hpp"
#include "eval/metrics.hpp"
#include "pipeline/estimator.hpp"
#include "test_support.hpp"

using namespace lidarflow;

namespace {

struct Golden {
    const char *id;
    double sf, d0;  // recorded SF and D0 outliers [%] (occ), lidarflow kitti --lidar paper
};
// Recorded 2026-12-01 from a clean build with `lidarflow kitti --root K --lidar paper` (seed 1),
// after stage 4 let a LiDAR point anchor superpixels up to 18 px away instead of 12
// (interpolation.lidar_anchor_distance: 8.59 -> 8.47 % over seeds 1-8; over placements of the
// paper protocol's grids 9.59 -> 9.36 %). Single seeds spread by about +-0.5 points per frame:
// over seeds 1-8 the mean SF is 8.47 % (7.63 / 9.30), so the tolerance and the bound on the mean
// below allow for it.
constexpr Golden kGolden[] = {{"000002", 7.58, 5.79}, {"000003", 9.59, 7.34}};
constexpr double kTolerance = 1.0;  // points; covers float differences across CPUs/compilers
constexpr double kMeanBound = 9.0;  // the seed mean plus the seed spread (the paper: 11.52 %)

// The real Velodyne scan at t0 (`lidarflow kitti --lidar velodyne`, seed 1), recorded
// 2026-12-01 (seeds 1-4: SF 4.03 %; the static-d1 rule had taken seeds 1-8 from 4.21 to 4.07 %
// and the anchor distance hardly matters with a scan this dense); the estimator drops
// the points the camera cannot see (lidar.visibility_filter: SF 5.97 -> 4.21 %, D0 3.50 -> 1.73 %).
constexpr Golden kGoldenVelodyne[] = {{"000002", 3.14, 1.37}, {"000003", 5.15, 2.05}};
constexpr double kVelodyneMeanBound = 4.7;  // the seed mean plus the seed spread
constexpr double kVelodyneD0MeanBound = 2.0;  // the accuracy issue's D0 target with a real scan

// The realtime preset (decoupled stage 1: LiDAR-guided SGM, DIS with the rigid choice, 0.55
// size, 4 SGM paths, t1 stereo guided by the carried t0 points, edge-keeping upscale, stage
// 4's tolerances at its size), seed 1, recorded 2026-12-04; seeds 1-8: SF 8.73 %, its target
// 10 %.
constexpr Golden kGoldenRealtime[] = {{"000002", 6.01, 4.20}, {"000003", 11.14, 8.11}};
constexpr double kRealtimeMeanBound = 10.5;

std::string g_root;

struct Means {
    double sf = 0, d0 = 0;
};

// Runs the estimator (the paper's design unless `preset` says otherwise) on the golden frames with LiDAR from `lidar`, checks each frame
// against its record (and with `check`, if given) and returns the means over the frames.
Means score_golden(const Golden (&golden)[2], const eval::LidarInputOptions &lidar, const char *label,
                   const std::function<void(const eval::KittiFrame &, const SceneFlowField &)> &check = {},
                   const char *preset = "paper") {
    pipeline::EstimatorOptions opt = pipeline::EstimatorOptions::preset(preset);
    opt.threads = 2;
    const pipeline::Estimator estimator(opt);
    Means m;
    const std::vector<std::string> ids = test::kitti_ids();
    for (const Golden &g : golden) {
        if (std::find(ids.begin(), ids.end(), g.id) == ids.end()) continue;
        const eval::KittiFrame f = eval::load_kitti_frame(g_root, g.id, lidar);
        const pipeline::EstimatorResult r = estimator.run(f.input);
        if (check) check(f, r.dense);
        const eval::FrameScore s = eval::evaluate_frame(eval::load_ground_truth(g_root, g.id), r.dense, eval::EvalOptions{});
        const double sf = s.dense.occ.sf.outlier_pct(), d0 = s.dense.occ.d0.outlier_pct();
        std::printf("%s%s: SF %.2f %% (golden %.2f), D0 %.2f %% (golden %.2f), %.2f s\n", g.id, label, sf, g.sf, d0,
                    g.d0, r.total_seconds);
        assert_true(std::fabs(sf - g.sf) <= kTolerance);
        assert_true(d0 <= g.d0 + kTolerance);
        m.sf += sf / static_cast<double>(ids.size());
        m.d0 += d0 / static_cast<double>(ids.size());
    }
    return m;
}

void golden_frames(void **) {
    const Means m = score_golden(kGolden, {}, "", [](const eval::KittiFrame &f, const SceneFlowField &out) {
        assert_int_equal(cv::countNonZero(out.valid), out.valid.rows * out.valid.cols);  // dense
        for (const LidarPoint &p : f.input.lidar0.points)  // LiDAR d0 is honoured exactly
            assert_float_equal(out.d0(p.y, p.x), p.disparity, 1e-4);
    });
    std::printf("mean SF %.2f %% (bound %.2f %%)\n", m.sf, kMeanBound);
    if (test::kitti_all_frames()) assert_true(m.sf <= kMeanBound);
}

void golden_frames_velodyne(void **) {
    eval::LidarInputOptions velodyne;
    velodyne.protocol = eval::LidarProtocol::Velodyne;
    velodyne.points = 0;  // the whole scan
    const Means m = score_golden(kGoldenVelodyne, velodyne, ", Velodyne", [](const eval::KittiFrame &f, const SceneFlowField &) {
        assert_true(f.input.lidar0.points.size() > 15000);
    });
    std::printf("Velodyne: mean SF %.2f %% (bound %.2f %%), mean D0 %.2f %% (bound %.2f %%)\n", m.sf,
                kVelodyneMeanBound, m.d0, kVelodyneD0MeanBound);
    if (test::kitti_all_frames()) {
        assert_true(m.sf <= kVelodyneMeanBound);
        assert_true(m.d0 <= kVelodyneD0MeanBound);
    }
}

// The realtime preset with 16 of the scan's 64 beams (`--lidar velodyne --beams 16`, seed 1),
// recorded 2026-12-04; the bound is the preset's 16-beam target.
constexpr Golden kGoldenRealtime16Beams[] = {{"000002", 3.68, 2.34}, {"000003", 6.86, 3.97}};
constexpr double kRealtime16BeamMeanBound = 5.5;

void golden_frames_realtime(void **) {
    const Means m = score_golden(kGoldenRealtime, {}, ", realtime", [](const eval::KittiFrame &f, const SceneFlowField &out) {
        assert_int_equal(cv::countNonZero(out.valid), out.valid.rows * out.valid.cols);
        for (const LidarPoint &p : f.input.lidar0.points)
            assert_float_equal(out.d0(p.y, p.x), p.disparity, 1e-4);
    }, "realtime");
    std::printf("realtime: mean SF %.2f %% (bound %.2f %%)\n", m.sf, kRealtimeMeanBound);
    if (test::kitti_all_frames()) assert_true(m.sf <= kRealtimeMeanBound);
}

void golden_frames_realtime_16_beams(void **) {
    eval::LidarInputOptions beams16;
    beams16.protocol = eval::LidarProtocol::Velodyne;
    beams16.points = 0;
    beams16.beams = 16;
    const Means m = score_golden(kGoldenRealtime16Beams, beams16, ", realtime, 16 beams",
                                 [](const eval::KittiFrame &f, const SceneFlowField &) {
                                     assert_true(f.input.lidar0.points.size() > 3000);
                                 }, "realtime");
    std::printf("realtime, 16 beams: mean SF %.2f %% (bound %.2f %%)\n", m.sf, kRealtime16BeamMeanBound);
    if (test::kitti_all_frames()) assert_true(m.sf <= kRealtime16BeamMeanBound);
}

}  // namespace

int main() {
    g_root = test::kitti_dir_or_skip("pipeline_kitti");
    const struct CMUnitTest tests[] = {cmocka_unit_test(golden_frames), cmocka_unit_test(golden_frames_velodyne),
                                       cmocka_unit_test(golden_frames_realtime),
                                       cmocka_unit_test(golden_frames_realtime_16_beams)};
    return cmocka_run_group_tests_name("pipeline_kitti", tests, nullptr, nullptr);
}
