// SPDX-License-Identifier: MIT
// Running the estimator below the input resolution (processing_scale): how
// frames are brought down (images, LiDAR, camera), how fields come back up, and the complete
// estimator at half resolution on a synthetic scene.
#include <cmath>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "eval/metrics.hpp"
#include "lidar/visibility_filter.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/resolution.hpp"
#include "synth/scene.hpp"
#include "synth_fields.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::pipeline;

namespace {

FrameInput gray_frame(int w, int h) {
    FrameInput f;
    for (cv::Mat *m : {&f.left0, &f.right0, &f.left1, &f.right1}) {
        *m = cv::Mat(h, w, CV_8UC1);
        cv::randu(*m, 0, 255);
    }
    f.lidar0 = {w, h, {}};
    f.lidar1 = {w, h, {}};
    return f;
}

void downscale_moves_lidar_and_camera(void **) {
    FrameInput f = gray_frame(40, 20);
    f.lidar0.points = {{5, 7, 10.0f}, {4, 6, 12.0f}, {39, 19, 3.0f}};  // the first two share a small pixel
    f.lidar1.points = {{0, 0, 8.0f}};
    f.camera = {100, 100, 19.5, 9.5, 0.5};
    const cv::Size size = scaled_size(40, 20, 0.5);
    assert_int_equal(size.width, 20);
    assert_int_equal(size.height, 10);
    const FrameInput s = downscale_frame(f, size);
    assert_int_equal(s.left0.cols, 20);
    assert_int_equal(s.right1.rows, 10);
    assert_int_equal(s.lidar0.width, 20);
    assert_int_equal(static_cast<int>(s.lidar0.points.size()), 2);
    bool shared = false, corner = false;
    for (const LidarPoint &p : s.lidar0.points) {
        if (p.x == 2 && p.y == 3) shared = p.disparity == 6.0f;  // 12 * 0.5: the nearer wins
        if (p.x == 19 && p.y == 9) corner = p.disparity == 1.5f;
    }
    assert_true(shared && corner);
    assert_int_equal(static_cast<int>(s.lidar1.points.size()), 1);
    assert_true(s.camera.fx == 50 && s.camera.fy == 50 && s.camera.baseline == 0.5);
    assert_true(s.camera.cx == 9.5 && s.camera.cy == 4.5);  // the image centre stays the centre
    // The mean grey level survives area averaging.
    assert_true(std::fabs(cv::mean(s.left0)[0] - cv::mean(f.left0)[0]) < 1.0);
}

void downscale_rejects_bad_input(void **) {
    const cv::Size size(20, 10);
    FrameInput f = gray_frame(40, 20);
    f.right1 = cv::Mat();
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { downscale_frame(f, size); }));
    f = gray_frame(40, 20);
    f.left1 = cv::Mat(21, 40, CV_8UC1, cv::Scalar(0));
    assert_true(test::throws_code(ErrorCode::SizeMismatch, [&] { downscale_frame(f, size); }));
    f = gray_frame(40, 20);
    f.lidar0.points = {{3, 3, std::nanf("")}};
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { downscale_frame(f, size); }));
    f.lidar0.points = {{40, 3, 5.0f}};  // outside at full size, would fit the small grid's rounding
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { downscale_frame(f, size); }));
    f.lidar0 = {41, 20, {{3, 3, 5.0f}}};
    assert_true(test::throws_code(ErrorCode::SizeMismatch, [&] { downscale_frame(f, size); }));
    f = gray_frame(40, 20);
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { downscale_frame(f, cv::Size(41, 10)); }));
}

void upscale_scales_values_and_keeps_holes(void **) {
    SceneFlowField s = SceneFlowField::zeros(4, 3);
    s.u.setTo(1.0f);
    s.v.setTo(-2.0f);
    s.d0.setTo(3.0f);
    s.d1.setTo(4.0f);
    s.confidence.setTo(0.5f);
    s.valid.setTo(1);
    s.valid(1, 3) = 0;  // one hole
    const SceneFlowField b = upscale_field(s, 8, 6);
    assert_int_equal(b.width(), 8);
    assert_int_equal(b.height(), 6);
    assert_true(b.u(0, 0) == 2.0f && b.v(0, 0) == -4.0f && b.d0(0, 0) == 6.0f && b.d1(5, 7) == 8.0f);
    assert_true(b.confidence(0, 0) == 0.5f);  // not a length
    assert_false(b.valid(2, 6) || b.valid(3, 7));  // the hole's own block stays a hole
    assert_true(b.valid(2, 5) && b.u(2, 5) == 2.0f);  // its neighbours take the nearest value
    // A linear ramp is reproduced between the small pixels' centres.
    SceneFlowField r = SceneFlowField::zeros(4, 1);
    r.valid.setTo(1);
    for (int x = 0; x < 4; ++x) r.d0(0, x) = static_cast<float>(x);
    const SceneFlowField rb = upscale_field(r, 8, 2);
    assert_float_equal(rb.d0(0, 2), 2.0 * 0.75, 1e-5);  // small x = 0.75
    assert_float_equal(rb.d0(1, 3), 2.0 * 1.25, 1e-5);
    assert_true(upscale_field(SceneFlowField{}, 8, 6).u.empty());
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { upscale_field(s, 3, 6); }));
    SceneFlowField big = b;
    restore_lidar_d0(big, SparseLidar{8, 6, {{1, 1, 7.25f}, {6, 2, 9.0f}}});
    assert_true(big.d0(1, 1) == 7.25f);
    assert_true(big.d0(2, 6) == 0.0f);  // invalid pixels stay untouched
}

// A depth edge between two small pixels: blended without the images, each full pixel takes the
// side whose intensity it has with them; a jump below the edge step still blends.
void upscale_keeps_edges_the_image_shows(void **) {
    SceneFlowField s = SceneFlowField::zeros(4, 1);
    s.valid.setTo(1);
    const float d[4] = {10, 10, 30, 30};
    for (int x = 0; x < 4; ++x) s.d0(0, x) = d[x];
    cv::Mat small(1, 4, CV_8UC1), full(2, 8, CV_8UC1);
    for (int x = 0; x < 4; ++x) small.at<uchar>(0, x) = x < 2 ? 40 : 200;
    for (int x = 0; x < 8; ++x) full.at<uchar>(0, x) = full.at<uchar>(1, x) = x < 4 ? 40 : 200;
    const SceneFlowField blend = upscale_field(s, 8, 2);
    const EdgeGuide guide(small, full, 3.0f);
    const SceneFlowField edge = upscale_field(s, 8, 2, &guide);
    assert_float_equal(blend.d0(0, 3), 2 * (10 + 0.25 * 20), 1e-4);  // small x = 1.25: mid-air
    assert_float_equal(edge.d0(0, 3), 20.0, 1e-4);
    assert_float_equal(edge.d0(0, 4), 60.0, 1e-4);
    const EdgeGuide off(small, full, 0.0f), coarse(small, full, 25.0f);
    assert_true(test::same_field(upscale_field(s, 8, 2, &off), blend));
    assert_true(test::same_field(upscale_field(s, 8, 2, &coarse), blend));
    // BGR images give the same choice; guides of another size are refused.
    cv::Mat small3, full3;
    cv::cvtColor(small, small3, cv::COLOR_GRAY2BGR);
    cv::cvtColor(full, full3, cv::COLOR_GRAY2BGR);
    const EdgeGuide bgr(small3, full3, 3.0f);
    assert_true(test::same_field(upscale_field(s, 8, 2, &bgr), edge));
    // Rows shared among threads give the same field.
    assert_true(test::same_field(upscale_field(s, 8, 2, &guide, 3), edge));
    assert_true(test::throws_code(ErrorCode::SizeMismatch, [&] { upscale_field(s, 16, 4, &guide); }));
}

void half_resolution_estimator(void **) {
    const synth::SynthScene s = test::render_scene(320, 96, 3);
    FrameInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, {}};
    EstimatorOptions o;
    o.processing_scale = 0.5;
    o.threads = 2;
    o.matching.min_coarsest_height = 16;
    const EstimatorResult r = Estimator(o).run(in);
    assert_int_equal(r.dense.width(), 320);
    assert_int_equal(r.dense.height(), 96);
    assert_int_equal(cv::countNonZero(r.dense.valid), 320 * 96);
    assert_int_equal(r.forward.width(), 320);
    // The input checks come first, on the input itself.
    assert_true(r.timings.size() > 2 && r.timings[0].name == "input_quality" && r.timings[1].name == "downscale" &&
                r.timings.back().name == "upscale");
    // Every point the visibility filter keeps is restored at full resolution.
    for (const LidarPoint &p : lidar::remove_hidden_points(s.lidar0, o.lidar_visibility).points)
        assert_true(r.dense.d0(p.y, p.x) == p.disparity);
    long n = 0, bad = 0;
    for (int y = 0; y < 96; ++y)
        for (int x = 0; x < 320; ++x) {
            if (s.disp0_occ(y, x) < 0 || s.disp1_occ(y, x) < 0 || !s.flow_occ.valid(y, x)) continue;
            ++n;
            bad += (eval::disparity_outlier(s.disp0_occ(y, x), r.dense.d0(y, x)) ||
                    eval::disparity_outlier(s.disp1_occ(y, x), r.dense.d1(y, x)) ||
                    eval::flow_outlier(s.flow_occ.u(y, x), s.flow_occ.v(y, x), r.dense.u(y, x), r.dense.v(y, x)))
                       ? 1
                       : 0;
        }
    const double sf = 100.0 * bad / n;
    std::printf("half resolution: SF outliers %.2f %% on %ld pixels\n", sf, n);
    assert_true(sf < 25.0);
    // Only the output kept (the C ABI's setting): the same output, the other fields empty.
    o.keep_stage_fields = false;
    const EstimatorResult lean = Estimator(o).run(in);
    for (const auto &[a, b] : {std::pair{&lean.dense.d0, &r.dense.d0}, {&lean.dense.d1, &r.dense.d1},
                               {&lean.dense.u, &r.dense.u}, {&lean.dense.v, &r.dense.v}})
        assert_int_equal(cv::norm(*a, *b, cv::NORM_INF), 0);
    assert_true(lean.forward.u.empty() && lean.after_fb.u.empty() && lean.sparse.u.empty());
    o.last_stage = Stage::Sparse;
    const EstimatorResult sparse_only = Estimator(o).run(in);
    assert_int_equal(sparse_only.output().width(), 320);
    assert_true(sparse_only.forward.u.empty() && sparse_only.dense.u.empty());
    EstimatorOptions bad_scale;
    bad_scale.processing_scale = 0.1;
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { Estimator e(bad_scale); }));
    bad_scale.processing_scale = std::nan("");
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { Estimator e(bad_scale); }));
}

// A LiDAR point the camera cannot see (the background's disparity, 3 px inside a near surface
// whose points surround it) is removed before every stage: a scaled run restores the LiDAR d0
// of the points it ran with, so the pixel keeps the estimate instead of the hidden value.
void hidden_lidar_point_is_not_used(void **) {
    const synth::SynthScene s = test::render_scene(320, 96, 3);
    FrameInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, {}};
    const int hx = 160, hy = 70;
    const float near = s.disp0_occ(hy, hx) > 0 ? s.disp0_occ(hy, hx) : 20.0f;
    in.lidar0.points.clear();
    for (int dx = -6; dx <= 6; dx += 3)
        if (dx != 0) in.lidar0.points.push_back({hx + dx, hy, near});
    const float hidden = near * 0.3f;
    in.lidar0.points.push_back({hx, hy, hidden});
    // At full resolution the matcher fixes a LiDAR pixel's d0 and stage 4 keeps it; at half
    // resolution the scaled run restores it.
    for (const double scale : {1.0, 0.5}) {
        EstimatorOptions o;
        o.processing_scale = scale;
        o.threads = 2;
        o.matching.min_coarsest_height = 16;
        o.keep_stage_fields = false;
        const EstimatorResult kept = Estimator([&] {
            EstimatorOptions off = o;
            off.lidar_visibility.enabled = false;
            return off;
        }()).run(in);
        assert_true(kept.dense.d0(hy, hx) == hidden);
        const EstimatorResult r = Estimator(o).run(in);
        assert_true(r.dense.d0(hy, hx) != hidden);
        assert_true(r.dense.d0(hy, hx + 3) == near);  // the visible neighbours stay
        std::printf("hidden LiDAR point, scale %.1f: d0 %.2f with the filter, %.2f without (near surface %.2f)\n",
                    scale, r.dense.d0(hy, hx), kept.dense.d0(hy, hx), near);
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(downscale_moves_lidar_and_camera),
        cmocka_unit_test(downscale_rejects_bad_input),
        cmocka_unit_test(upscale_scales_values_and_keeps_holes),
        cmocka_unit_test(half_resolution_estimator),
        cmocka_unit_test(upscale_keeps_edges_the_image_shows),
        cmocka_unit_test(hidden_lidar_point_is_not_used),
    };
    return cmocka_run_group_tests_name("pipeline_resolution", tests, nullptr, nullptr);
}
