// SPDX-License-Identifier: MIT
// KITTI scores on small hand-built cases whose counts are known by construction: the 3 px / 5 %
// outlier rule for disparity and flow, the SF union over valid ground truth, densities, the two
// fill modes, the Table II regions, frame aggregation, and input validation.
#include <cmath>
#include <limits>
#include "core/error.hpp"
#include "eval/metrics.hpp"
// cmocka.h defines fail(), which breaks <ios>: include it after every C++ header. Its 1.1.5
// header has no extern "C" of its own, so wrap it here (test_support.hpp's include is then a no-op).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;
using eval::Counts;
using eval::EvalOptions;
using eval::FillMode;

namespace {

constexpr int W = 10, H = 10;


void expect_near(double got, double want, double tol, const char *what) {
    if (!(std::fabs(got - want) <= tol)) fail_msg("%s: got %.10g, want %.10g", what, got, want);
}

void expect_counts(const Counts &c, int64_t n_gt, int64_t n_est, int64_t n_total, int64_t n_err, const char *what) {
    if (c.n_gt != n_gt || c.n_est != n_est || c.n_total != n_total || c.n_err != n_err)
        fail_msg("%s: got gt=%lld est=%lld total=%lld err=%lld, want %lld %lld %lld %lld", what,
                 (long long)c.n_gt, (long long)c.n_est, (long long)c.n_total, (long long)c.n_err,
                 (long long)n_gt, (long long)n_est, (long long)n_total, (long long)n_err);
}

// d0 = 10, d1 = 100, flow = (60, 80) (length 100) everywhere, all valid.
eval::FrameGroundTruth uniform_gt() {
    eval::FrameGroundTruth gt;
    gt.occ.d0 = DisparityMap(H, W, 10.0f);
    gt.occ.d1 = DisparityMap(H, W, 100.0f);
    gt.occ.flow = FlowField::zeros(W, H);
    gt.occ.flow.u.setTo(60.0f);
    gt.occ.flow.v.setTo(80.0f);
    gt.occ.flow.valid.setTo(1);
    return gt;
}

eval::Estimate copy_of(const eval::GroundTruth &g) {
    return {g.d0.clone(), g.d1.clone(), {g.flow.u.clone(), g.flow.v.clone(), g.flow.valid.clone()}};
}

void ground_truth_scores_perfectly(void **) {
    eval::FrameGroundTruth gt = uniform_gt();
    // Holes in the ground truth (and at the same places in the estimate) must not matter.
    gt.occ.d0(3, 4) = -1;
    gt.occ.flow.valid(7, 7) = 0;
    gt.has_noc = true;
    gt.noc = {gt.occ.d0.clone(), gt.occ.d1.clone(), {gt.occ.flow.u.clone(), gt.occ.flow.v.clone(), gt.occ.flow.valid.clone()}};
    gt.noc.d1(0, 0) = -1;
    for (FillMode mode : {FillMode::Filled, FillMode::EstimateOnly}) {
        const eval::FrameScore s = eval::evaluate_frame(gt, copy_of(gt.occ), {mode, 15});
        assert_true(s.dense.has_noc);
        for (const eval::ComponentScores *c : {&s.dense.occ, &s.dense.noc})
            for (const Counts *k : {&c->d0, &c->d1, &c->fl, &c->sf}) {
                assert_true(k->n_gt > 0);
                assert_int_equal(k->n_err, 0);
                assert_true(k->n_total == k->n_gt);
                expect_near(k->outlier_pct(), 0.0, 0.0, "outliers");
                expect_near(k->density_pct(), 100.0, 0.0, "density");
            }
        for (const Counts *k : {&s.dense.occ.d0, &s.dense.occ.d1, &s.dense.occ.fl})
            expect_near(k->epe(), 0.0, 0.0, "epe");
        expect_counts(s.dense.occ.d0, 99, 99, 99, 0, "d0 gt");
        expect_counts(s.dense.occ.fl, 99, 99, 99, 0, "fl gt");
        expect_counts(s.dense.occ.sf, 98, 98, 98, 0, "sf gt");
        expect_counts(s.dense.noc.sf, 97, 97, 97, 0, "sf noc gt");
    }
}

void disparity_three_px_and_five_percent(void **) {
    const eval::FrameGroundTruth gt = uniform_gt();
    eval::Estimate e = copy_of(gt.occ);
    // d0 GT = 10: 7 pixels off by +4 -> 4 > 3 and 40 % > 5 %: outliers.
    for (int i = 0; i < 7; ++i) e.d0(0, i) += 4.0f;
    // Exactly 3 px off is not an outlier (strict >).
    e.d0(1, 0) -= 3.0f;
    // d1 GT = 100: off by 4 -> 4 % < 5 %: not outliers; off by 6 -> 6 %: outliers (3 pixels).
    for (int i = 0; i < 9; ++i) e.d1(2, i) -= 4.0f;
    for (int i = 0; i < 3; ++i) e.d1(3, i) += 6.0f;
    // Exactly 5 % (5 px of 100) IS an outlier: the devkit divides in float, and
    // 5.0f / 100.0f = 0.0500000007 > 0.05.
    e.d1(4, 0) += 5.0f;
    const eval::FrameScore s = eval::evaluate_frame(gt, e, {});
    expect_counts(s.dense.occ.d0, 100, 100, 100, 7, "d0");
    expect_counts(s.dense.occ.d1, 100, 100, 100, 4, "d1");
    expect_near(s.dense.occ.d0.outlier_pct(), 7.0, 1e-12, "d0 %");
    expect_near(s.dense.occ.d0.epe(), (7 * 4 + 3) / 100.0, 1e-9, "d0 epe");
    expect_near(s.dense.occ.d1.epe(), (9 * 4 + 3 * 6 + 5) / 100.0, 1e-9, "d1 epe");
    expect_counts(s.dense.occ.sf, 100, 100, 100, 11, "sf");  // disjoint rows 0, 3 and 4
    assert_false(s.dense.has_noc);
    assert_false(s.has_lidar);
}

void flow_magnitude_rule(void **) {
    eval::FrameGroundTruth gt = uniform_gt();
    eval::Estimate e = copy_of(gt.occ);
    // GT length 100: end-point error 4 is 4 % -> inlier; 6 -> outlier (2 pixels).
    for (int i = 0; i < 5; ++i) e.flow.u(0, i) += 4.0f;
    e.flow.u(1, 0) += 3.6f;  // (3.6, 4.8): error 6
    e.flow.v(1, 0) += 4.8f;
    e.flow.v(1, 1) -= 6.0f;
    // Zero GT flow: any error above 3 px is an outlier (relative error is infinite).
    gt.occ.flow.u(5, 5) = gt.occ.flow.v(5, 5) = 0.0f;
    e.flow.u(5, 5) = 3.5f;
    e.flow.v(5, 5) = 0.0f;
    gt.occ.flow.u(5, 6) = gt.occ.flow.v(5, 6) = 0.0f;
    e.flow.u(5, 6) = 2.9f;
    e.flow.v(5, 6) = 0.0f;
    const eval::FrameScore s = eval::evaluate_frame(gt, e, {});
    expect_counts(s.dense.occ.fl, 100, 100, 100, 3, "fl");
    expect_near(s.dense.occ.fl.epe(), (5 * 4 + 6 + 6 + 3.5 + 2.9) / 100.0, 1e-6, "fl epe");
    assert_true(eval::flow_outlier(0, 0, 3.5f, 0));
    assert_false(eval::flow_outlier(0, 0, 3.0f, 0));
    assert_true(eval::disparity_outlier(0, 3.5f));
    assert_true(eval::disparity_outlier(80, 84));  // 4 / 80 in float: just above 0.05
    assert_false(eval::disparity_outlier(100, 104.9f));
    assert_false(eval::disparity_outlier(10, 13));
    assert_true(eval::disparity_outlier(60, 63.5f));
}

void scene_flow_is_union_over_valid_gt(void **) {
    eval::FrameGroundTruth gt = uniform_gt();
    eval::Estimate e = copy_of(gt.occ);
    e.d0(0, 0) += 10;  // D0 only
    e.d1(0, 1) += 10;  // D1 only
    e.flow.u(0, 2) += 10;  // Fl only
    e.d0(0, 3) += 10;  // all three at one pixel: one SF outlier
    e.d1(0, 3) += 10;
    e.flow.v(0, 3) += 10;
    e.d0(0, 4) += 10;  // D0 outlier where the d1 GT is invalid: counts for D0, not for SF
    gt.occ.d1(0, 4) = -1;
    gt.occ.flow.valid(9, 9) = 0;  // invalid flow GT: wildly wrong estimate there is ignored
    e.flow.u(9, 9) = 500;
    e.d1(9, 9) = 500;  // but D1 GT is valid there: a D1 outlier, not an SF one
    const eval::FrameScore s = eval::evaluate_frame(gt, e, {});
    expect_counts(s.dense.occ.d0, 100, 100, 100, 3, "d0");
    expect_counts(s.dense.occ.d1, 99, 99, 99, 3, "d1");
    expect_counts(s.dense.occ.fl, 99, 99, 99, 2, "fl");
    expect_counts(s.dense.occ.sf, 98, 98, 98, 4, "sf");
}

void invalid_ground_truth_is_ignored(void **) {
    eval::FrameGroundTruth gt = uniform_gt();
    eval::Estimate e = copy_of(gt.occ);
    for (int x = 0; x < W; ++x) {
        gt.occ.d0(4, x) = kInvalidDisparity;
        e.d0(4, x) = 55;
    }
    const eval::FrameScore s = eval::evaluate_frame(gt, e, {});
    expect_counts(s.dense.occ.d0, 90, 90, 90, 0, "d0");
    expect_counts(s.dense.occ.sf, 90, 90, 90, 0, "sf");
    expect_near(s.dense.occ.d0.epe(), 0.0, 0.0, "d0 epe");
}

void holes_filled_or_skipped(void **) {
    eval::FrameGroundTruth gt = uniform_gt();
    for (int x = 3; x < 6; ++x) gt.occ.d0(2, x) = 30;  // GT foreground in the middle of row 2
    eval::Estimate e = copy_of(gt.occ);
    for (int x = 3; x < 6; ++x) e.d0(2, x) = -1;   // hole over the foreground: filled with 10
    e.d1(5, 5) = -1;                                // a d1 hole: filled with 100, correct
    e.flow.valid(6, 0) = e.flow.valid(6, 1) = 0;    // flow hole at the row start: copied, correct
    e.flow.u(6, 0) = std::numeric_limits<float>::quiet_NaN();  // never read: invalid pixel

    const eval::FrameScore f = eval::evaluate_frame(gt, e, {FillMode::Filled, 15});
    expect_counts(f.dense.occ.d0, 100, 97, 100, 3, "filled d0");
    expect_counts(f.dense.occ.d1, 100, 99, 100, 0, "filled d1");
    expect_counts(f.dense.occ.fl, 100, 98, 100, 0, "filled fl");
    // Devkit: SF density follows the d0 estimate only.
    expect_counts(f.dense.occ.sf, 100, 97, 100, 3, "filled sf");
    expect_near(f.dense.occ.d0.epe(), 60.0 / 100.0, 1e-9, "filled d0 epe");
    expect_near(f.dense.occ.d0.density_pct(), 97.0, 1e-12, "density d0");
    expect_near(f.dense.occ.fl.density_pct(), 98.0, 1e-12, "density fl");

    const eval::FrameScore o = eval::evaluate_frame(gt, e, {FillMode::EstimateOnly, 15});
    expect_counts(o.dense.occ.d0, 100, 97, 97, 0, "est-only d0");
    expect_counts(o.dense.occ.d1, 100, 99, 99, 0, "est-only d1");
    expect_counts(o.dense.occ.fl, 100, 98, 98, 0, "est-only fl");
    // Scored SF pixels need all three estimates: 100 - 3 - 1 - 2.
    expect_counts(o.dense.occ.sf, 100, 97, 94, 0, "est-only sf");
    expect_near(o.dense.occ.d0.density_pct(), 97.0, 1e-12, "est-only density");
}

void scene_flow_field_overload(void **) {
    const eval::FrameGroundTruth gt = uniform_gt();
    SceneFlowField sf = SceneFlowField::zeros(W, H);
    sf.d0.setTo(10.0f);
    sf.d1.setTo(100.0f);
    sf.u.setTo(60.0f);
    sf.v.setTo(80.0f);
    sf.valid.setTo(1);
    sf.valid(0, 0) = 0;
    sf.u(0, 0) = std::numeric_limits<float>::infinity();  // ignored: invalid pixel
    sf.d0(1, 1) = 20;  // outlier
    sf.d1(2, 2) = -5;  // a hole of d1 only
    const eval::FrameScore s = eval::evaluate_frame(gt, sf, {FillMode::EstimateOnly, 15});
    expect_counts(s.dense.occ.d0, 100, 99, 99, 1, "d0");
    expect_counts(s.dense.occ.d1, 100, 98, 98, 0, "d1");
    expect_counts(s.dense.occ.fl, 100, 99, 99, 0, "fl");
    expect_counts(s.dense.occ.sf, 100, 99, 98, 1, "sf");
    sf.d1(3, 3) = std::numeric_limits<float>::quiet_NaN();
    assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, sf, {}); }) == ErrorCode::InvalidArgument);
}

void table_two_regions(void **) {
    eval::FrameGroundTruth gt;
    gt.occ.d0 = DisparityMap(20, 20, 10.0f);
    gt.occ.d1 = DisparityMap(20, 20, 10.0f);
    gt.occ.flow = FlowField::zeros(20, 20);
    gt.occ.flow.valid.setTo(1);
    eval::Estimate e = copy_of(gt.occ);
    DisparityMap seeds(20, 20, kInvalidDisparity);
    seeds(5, 5) = 10;
    seeds(0, 19) = 10;  // a seed at the border: its 3x3 window keeps 4 pixels
    e.d0(5, 5) = 20;      // outlier at a seed
    e.d1(6, 6) = 20;      // outlier in its window
    e.flow.u(15, 15) = 9;  // outlier outside any window
    e.flow.u(1, 18) = 9;   // outlier in the border window
    const eval::FrameScore s = eval::evaluate_frame(gt, e, {FillMode::Filled, 3}, &seeds, "t2");
    assert_true(s.has_lidar);
    assert_int_equal(s.n_seeds, 2);
    expect_counts(s.seeds.occ.sf, 2, 2, 2, 1, "seeds");
    expect_counts(s.window.occ.sf, 13, 13, 13, 3, "window");
    expect_counts(s.window_excl_seeds.occ.sf, 11, 11, 11, 2, "window without seeds");
    expect_counts(s.dense.occ.sf, 400, 400, 400, 4, "dense");
    expect_counts(s.seeds.occ.d0, 2, 2, 2, 1, "seeds d0");
    assert_string_equal(s.id.c_str(), "t2");

    // A bigger window covers more pixels; an even window is rejected.
    const eval::FrameScore s5 = eval::evaluate_frame(gt, e, {FillMode::Filled, 5}, &seeds);
    expect_counts(s5.window.occ.sf, 25 + 9, 25 + 9, 25 + 9, 3, "window 5");
    assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {FillMode::Filled, 4}, &seeds); }) ==
                ErrorCode::InvalidArgument);
    assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {FillMode::Filled, 0}, &seeds); }) ==
                ErrorCode::InvalidArgument);
    const DisparityMap small(19, 20, 1.0f);
    assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {}, &small); }) == ErrorCode::SizeMismatch);
}

void pooled_versus_mean_over_frames(void **) {
    // Frame a: 1 D0 outlier of 100. Frame b: only 50 valid D0 GT pixels, 25 outliers.
    eval::FrameGroundTruth ga = uniform_gt(), gb = uniform_gt();
    eval::Estimate ea = copy_of(ga.occ), eb = copy_of(gb.occ);
    ea.d0(0, 0) = 30;
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < W; ++x) gb.occ.d0(y, x) = kInvalidDisparity;
    for (int i = 0; i < 25; ++i) eb.d0(5 + i / W, i % W) = 14;
    eb.d0(9, 9) = -1;  // one hole: density 49/50 in b
    const std::vector<eval::FrameScore> frames = {eval::evaluate_frame(ga, ea, {}, nullptr, "a"),
                                                  eval::evaluate_frame(gb, eb, {}, nullptr, "b")};
    const eval::Summary s = eval::summarize(frames);
    expect_counts(s.pooled.dense.occ.d0, 150, 149, 150, 26, "pooled d0");
    expect_near(s.pooled.dense.occ.d0.outlier_pct(), 100.0 * 26 / 150, 1e-9, "pooled %");
    expect_near(s.mean_dense.occ.d0.outlier_pct, (1.0 + 50.0) / 2, 1e-9, "mean %");
    expect_near(s.pooled.dense.occ.d0.epe(), (20.0 + 25 * 4) / 150, 1e-9, "pooled epe");
    expect_near(s.mean_dense.occ.d0.epe, (20.0 / 100 + 100.0 / 50) / 2, 1e-9, "mean epe");
    expect_near(s.pooled.dense.occ.d0.density_pct(), 100.0 * 149 / 150, 1e-9, "pooled density");
    expect_near(s.mean_dense.occ.d0.density_pct, (100.0 + 98.0) / 2, 1e-9, "mean density");
    assert_int_equal(s.mean_dense.occ.d0.frames_scored, 2);
    assert_string_equal(s.pooled.id.c_str(), "pooled");
    assert_false(s.pooled.dense.has_noc);
    assert_false(s.pooled.has_lidar);
    assert_true(test::error_code_of([] { eval::summarize({}); }) == ErrorCode::InvalidArgument);
}

void undefined_rates_are_nan(void **) {
    eval::FrameGroundTruth gt = uniform_gt();
    gt.occ.flow.valid.setTo(0);
    const eval::FrameScore s = eval::evaluate_frame(gt, copy_of(uniform_gt().occ), {});
    assert_int_equal(s.dense.occ.fl.n_gt, 0);
    assert_true(std::isnan(s.dense.occ.fl.outlier_pct()));
    assert_true(std::isnan(s.dense.occ.sf.density_pct()));
    const eval::Summary sum = eval::summarize({s});
    assert_int_equal(sum.mean_dense.occ.fl.frames_scored, 0);
    assert_true(std::isnan(sum.mean_dense.occ.fl.outlier_pct));
}

void bad_inputs_throw(void **) {
    const eval::FrameGroundTruth gt = uniform_gt();
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    {
        eval::Estimate e = copy_of(gt.occ);
        e.d0(2, 3) = nan;
        assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {}); }) == ErrorCode::InvalidArgument);
        e.d0(2, 3) = -inf;  // even a "negative" infinity is rejected, not taken as a hole
        assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {}); }) == ErrorCode::InvalidArgument);
    }
    {
        eval::Estimate e = copy_of(gt.occ);
        e.flow.v(1, 1) = inf;
        assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {}); }) == ErrorCode::InvalidArgument);
    }
    {
        eval::Estimate e = copy_of(gt.occ);
        e.d1 = DisparityMap(H, W + 1, 1.0f);
        assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {}); }) == ErrorCode::SizeMismatch);
    }
    {
        eval::Estimate e = copy_of(gt.occ);
        e.flow.valid = cv::Mat1b::ones(H - 1, W);
        assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {}); }) == ErrorCode::SizeMismatch);
        e = copy_of(gt.occ);
        e.d0 = DisparityMap();
        assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, e, {}); }) == ErrorCode::InvalidArgument);
    }
    {
        eval::FrameGroundTruth g = uniform_gt();
        g.has_noc = true;  // noc announced but missing
        assert_true(test::error_code_of([&] { eval::evaluate_frame(g, copy_of(gt.occ), {}); }) == ErrorCode::InvalidArgument);
        g.noc = {DisparityMap(H + 1, W, 1.0f), g.occ.d1, g.occ.flow};
        assert_true(test::error_code_of([&] { eval::evaluate_frame(g, copy_of(gt.occ), {}); }) == ErrorCode::SizeMismatch);
    }
    {
        SceneFlowField sf = SceneFlowField::zeros(W, H);
        sf.valid = cv::Mat1b::ones(H, W + 2);
        assert_true(test::error_code_of([&] { eval::evaluate_frame(gt, sf, {}); }) == ErrorCode::SizeMismatch);
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(ground_truth_scores_perfectly),
        cmocka_unit_test(disparity_three_px_and_five_percent),
        cmocka_unit_test(flow_magnitude_rule),
        cmocka_unit_test(scene_flow_is_union_over_valid_gt),
        cmocka_unit_test(invalid_ground_truth_is_ignored),
        cmocka_unit_test(holes_filled_or_skipped),
        cmocka_unit_test(scene_flow_field_overload),
        cmocka_unit_test(table_two_regions),
        cmocka_unit_test(pooled_versus_mean_over_frames),
        cmocka_unit_test(undefined_rates_are_nan),
        cmocka_unit_test(bad_inputs_throw),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
