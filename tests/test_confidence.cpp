// SPDX-License-Identifier: MIT
// The result's confidence and how it is judged:
//  - add_measured_support raises the confidence where stage 1's match agrees with the result
//    nearby, leaves it where none does, and keeps it in [0, 1];
//  - sparsify: a confidence that ranks the outliers last follows the oracle's curve, one that
//    ranks them first never falls, and the share left at 80 % is 0 / 1 accordingly;
//  - on the shared KITTI frames with the real scan (skipped without LIDARFLOW_KITTI_DIR):
//    keeping the 80 % most confident pixels of `realtime` and `default` leaves at most 0.4 of
//    the SF outlier rate (mean of both frames).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "eval/kitti_eval.hpp"
#include "eval/kitti_runner.hpp"
#include "eval/sparsification.hpp"
#include "io/kitti_submission.hpp"
#include "pipeline/confidence.hpp"
#include "pipeline/estimator.hpp"
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

namespace {

void measured_support_raises_agreeing_pixels(void **) {
    SceneFlowField dense = SceneFlowField::zeros(20, 10), measured = SceneFlowField::zeros(20, 10);
    dense.valid.setTo(1);
    dense.confidence.setTo(0.5f);
    dense.u.setTo(3.0f);
    measured.u.setTo(3.0f);
    // Left half measured and agreeing, right half measured 5 px off; column 19 not valid.
    measured.valid.colRange(0, 19).setTo(1);
    measured.u.colRange(10, 20).setTo(8.0f);
    dense.valid(5, 19) = 0;
    pipeline::add_measured_support(dense, measured, 1, 1.0f, 0.25f);
    assert_true(std::fabs(dense.confidence(5, 2) - (0.5f + 0.25f) / 1.25f) < 1e-6f);  // full agreement
    assert_true(std::fabs(dense.confidence(5, 15) - 0.5f / 1.25f) < 1e-6f);           // none
    assert_true(dense.confidence(5, 10) > dense.confidence(5, 15) && dense.confidence(5, 10) < dense.confidence(5, 2));
    assert_true(dense.confidence(5, 19) == 0.5f);  // not valid: untouched
    // Another size: unchanged.
    SceneFlowField other = SceneFlowField::zeros(4, 4);
    const cv::Mat1f before = dense.confidence.clone();
    pipeline::add_measured_support(dense, other, 1, 1.0f, 0.25f);
    assert_true(cv::norm(before, dense.confidence, cv::NORM_INF) == 0);
}

void sparsification_against_the_oracle(void **) {
    const int w = 100, h = 10;
    eval::GroundTruth gt{DisparityMap(h, w, 10.0f), DisparityMap(h, w, 10.0f), FlowField::zeros(w, h)};
    gt.flow.valid.setTo(1);
    eval::Estimate est{DisparityMap(h, w, 10.0f), DisparityMap(h, w, 10.0f), FlowField::zeros(w, h)};
    est.flow.valid.setTo(1);
    cv::Mat1f good(h, w), bad(h, w);
    // 10 % outliers (d0 off by 5 px), spread over the image.
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool outlier = x % 10 == 3;
            if (outlier) est.d0(y, x) = 15.0f;
            good(y, x) = outlier ? 0.1f : 0.9f;
            bad(y, x) = outlier ? 0.9f : 0.1f;
        }
    const eval::Sparsification g = eval::sparsify(gt, est, good), b = eval::sparsify(gt, est, bad);
    assert_int_equal(g.pixels, w * h);
    assert_int_equal(static_cast<int>(g.rate.size()), 10);
    assert_true(std::fabs(g.rate[0] - 10.0) < 1e-9 && std::fabs(b.rate[0] - 10.0) < 1e-9);
    for (size_t k = 0; k < g.rate.size(); ++k) assert_true(std::fabs(g.rate[k] - g.oracle[k]) < 1e-9);
    assert_true(g.kept80_share == 0.0);
    assert_true(std::fabs(b.kept80_share - 1.25) < 1e-9);  // 10 % of 80 % kept are the outliers
    assert_true(b.area > g.area && std::fabs(g.area - g.oracle_area) < 1e-12);
    const std::string table = eval::format_sparsification({"a", "b"}, {g, b});
    assert_non_null(std::strstr(table.c_str(), "kept 80 %"));
    assert_true(test::throws_code(ErrorCode::SizeMismatch, [&] { eval::sparsify(gt, est, cv::Mat1f(3, 3, 0.0f)); }));
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { eval::sparsify(gt, est, good, 1); }));
}

void kitti_confidence_predicts_the_error(void **) {
    const std::string root = test::kitti_dir();
    if (root.empty()) {
        std::printf("skipped: LIDARFLOW_KITTI_DIR is not set to a KITTI training folder\n");
        skip();
    }
    eval::LidarInputOptions lidar;
    lidar.protocol = eval::LidarProtocol::Velodyne;
    lidar.points = 0;
    for (const char *preset : {"realtime", "default"}) {
        double share = 0;
        const std::vector<std::string> ids = test::kitti_ids();
        for (const std::string &id : ids) {
            const eval::KittiFrame f = eval::load_kitti_frame(root, id, lidar);
            pipeline::EstimatorOptions o = pipeline::EstimatorOptions::preset(preset);
            o.threads = 2;
            const SceneFlowField r = pipeline::Estimator(o).run(f.input).output();
            eval::Estimate est{io::field_disparity0(r), io::field_disparity1(r), io::field_flow(r)};
            const eval::Sparsification s = eval::sparsify(eval::load_ground_truth(root, id).occ, est, r.confidence);
            std::printf("%s %s: SF %.2f %%, kept 80 %% leaves %.3f of it, area %.2f (oracle %.2f)\n", preset, id.c_str(),
                        s.rate[0], s.kept80_share, s.area, s.oracle_area);
            share += s.kept80_share / static_cast<double>(ids.size());
        }
        if (test::kitti_all_frames()) assert_true(share <= 0.4);
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(measured_support_raises_agreeing_pixels),
        cmocka_unit_test(sparsification_against_the_oracle),
        cmocka_unit_test(kitti_confidence_predicts_the_error),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
