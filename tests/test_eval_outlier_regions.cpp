// SPDX-License-Identifier: MIT
// Outlier breakdown by region (lidarflow kitti --ablation): each region's counts on a 40x20
// hand-built frame whose region memberships and outliers are known by construction, additivity
// over frames, and input validation.
#include <limits>
#include <string>

#include "core/error.hpp"
#include "eval/outlier_regions.hpp"
// cmocka.h defines fail(), which breaks <ios>: include it after every C++ header.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;
using eval::OutlierBreakdown;

namespace {

constexpr int W = 40, H = 20;

// d0 = 20 everywhere except the 10 left columns (d0 = 50: near) and row 0 (d0 = 5: far);
// d1 = d0; flow (2, 0) except the 4 right columns, whose flow (10, 0) leaves the image.
// The noc ground truth lacks rows 10-11 (occluded: 2 x 26 pixels outside the right columns).
eval::FrameGroundTruth frame() {
    eval::FrameGroundTruth gt;
    gt.occ.d0 = DisparityMap(H, W, 20.0f);
    gt.occ.d0(cv::Rect(0, 0, 10, H)).setTo(50.0f);
    gt.occ.d0.row(0).setTo(5.0f);
    gt.occ.d1 = gt.occ.d0.clone();
    gt.occ.flow = FlowField::zeros(W, H);
    gt.occ.flow.u.setTo(2.0f);
    gt.occ.flow.u(cv::Rect(W - 4, 0, 4, H)).setTo(10.0f);
    gt.occ.flow.valid.setTo(1);
    gt.has_noc = true;
    gt.noc = {gt.occ.d0.clone(), gt.occ.d1.clone(),
              {gt.occ.flow.u.clone(), gt.occ.flow.v.clone(), gt.occ.flow.valid.clone()}};
    gt.noc.flow.valid.rowRange(10, 12).setTo(0);
    return gt;
}

eval::Estimate exact(const eval::FrameGroundTruth &gt) {
    return {gt.occ.d0.clone(), gt.occ.d1.clone(),
            {gt.occ.flow.u.clone(), gt.occ.flow.v.clone(), gt.occ.flow.valid.clone()}};
}

const eval::ComponentScores &region(const OutlierBreakdown &b, const std::string &family, const std::string &name) {
    for (const eval::OutlierRegion &r : b.regions)
        if (r.family == family && r.name == name) return r.scores;
    fail_msg("no region %s / %s", family.c_str(), name.c_str());
    return b.regions.front().scores;
}

void expect_sf(const eval::ComponentScores &c, int64_t pixels, int64_t outliers, const char *what) {
    if (c.sf.n_gt != pixels || c.sf.n_err != outliers)
        fail_msg("%s: got %lld pixels / %lld SF outliers, want %lld / %lld", what, (long long)c.sf.n_gt,
                 (long long)c.sf.n_err, (long long)pixels, (long long)outliers);
}

void regions_partition_the_pixels(void **) {
    const eval::FrameGroundTruth gt = frame();
    eval::Estimate est = exact(gt);
    // Outliers: d0 at (5, 5) (near, visible), d1 at (20, 10) (occluded), flow at (38, 3) (leaves).
    est.d0(5, 5) += 10.0f;
    est.d1(10, 20) += 10.0f;
    est.flow.u(3, 38) += 10.0f;
    DisparityMap seeds(H, W, kInvalidDisparity);
    seeds(15, 25) = 20.0f;  // one seed; 7.5 px around it is its window
    cv::Mat1b objects = cv::Mat1b::zeros(H, W);
    objects(cv::Rect(0, 0, 10, H)).setTo(3);

    const OutlierBreakdown b = eval::outlier_breakdown(gt, est, &seeds, &objects);
    expect_sf(region(b, "all", "all"), W * H, 3, "all");
    expect_sf(region(b, "at t1", "leaves the image"), 4 * H, 1, "leaves");
    expect_sf(region(b, "at t1", "occluded"), 2 * (W - 4), 1, "occluded");
    expect_sf(region(b, "at t1", "visible"), (H - 2) * (W - 4), 1, "visible");
    expect_sf(region(b, "depth", "near: d0 >= 40 px"), 10 * (H - 1), 1, "near");
    expect_sf(region(b, "depth", "far: d0 < 10 px"), W, 0, "far");
    expect_sf(region(b, "depth", "mid: d0 10-40 px"), (W - 10) * (H - 1), 2, "mid");
    expect_sf(region(b, "objects", "objects"), 10 * H, 1, "objects");
    expect_sf(region(b, "objects", "background"), (W - 10) * H, 2, "background");
    // The three LiDAR bins partition the frame, and the seed's own pixel is in the first.
    const int64_t near_seed = region(b, "LiDAR", "<= 7 px from a seed").sf.n_gt;
    assert_true(near_seed > 100 && near_seed < 200);  // a disc of radius 7.5 px, cut by the border
    assert_int_equal(near_seed + region(b, "LiDAR", "8-30 px").sf.n_gt + region(b, "LiDAR", "> 30 px").sf.n_gt,
                     W * H);
    // Which component failed is kept per region.
    assert_int_equal(region(b, "at t1", "occluded").d1.n_err, 1);
    assert_int_equal(region(b, "at t1", "occluded").d0.n_err, 0);
    assert_int_equal(region(b, "at t1", "leaves the image").fl.n_err, 1);

    // Without seeds, objects or noc ground truth those regions are left out.
    eval::FrameGroundTruth no_noc = gt;
    no_noc.has_noc = false;
    const OutlierBreakdown plain = eval::outlier_breakdown(no_noc, est, nullptr, nullptr);
    for (const eval::OutlierRegion &r : plain.regions) {
        assert_true(r.family != "LiDAR" && r.family != "objects");
        assert_true(r.name != "occluded");
    }
    expect_sf(region(plain, "at t1", "in the image"), (W - 4) * H, 2, "in the image");
}

void frames_add_up(void **) {
    const eval::FrameGroundTruth gt = frame();
    eval::Estimate est = exact(gt);
    est.d0(5, 5) += 10.0f;
    OutlierBreakdown total;
    total += eval::outlier_breakdown(gt, est, nullptr, nullptr);
    total += eval::outlier_breakdown(gt, est, nullptr, nullptr);
    expect_sf(region(total, "all", "all"), 2 * W * H, 2, "two frames");
    expect_sf(region(total, "depth", "near: d0 >= 40 px"), 2 * 10 * (H - 1), 2, "two frames, near");
    const std::string text = eval::format_outlier_breakdown(total, &total, "again");
    assert_true(text.find("leaves the image") != std::string::npos);
    assert_true(text.find("again") != std::string::npos);
}

void bad_inputs_are_refused(void **) {
    const eval::FrameGroundTruth gt = frame();
    const eval::Estimate est = exact(gt);
    const cv::Mat1b small = cv::Mat1b::zeros(H - 1, W);
    test::expect_error([&] { eval::outlier_breakdown(gt, est, nullptr, &small); }, ErrorCode::SizeMismatch);
    const DisparityMap seeds(H, W + 1, 3.0f);
    test::expect_error([&] { eval::outlier_breakdown(gt, est, &seeds, nullptr); }, ErrorCode::SizeMismatch);
    eval::Estimate nan = exact(gt);
    nan.flow.u(2, 2) = std::numeric_limits<float>::quiet_NaN();
    test::expect_error([&] { eval::outlier_breakdown(gt, nan, nullptr, nullptr); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { eval::outlier_breakdown(eval::FrameGroundTruth{}, est, nullptr, nullptr); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(regions_partition_the_pixels),
        cmocka_unit_test(frames_add_up),
        cmocka_unit_test(bad_inputs_are_refused),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
