// SPDX-License-Identifier: MIT
// The input-quality checks' own rules: the calibration size check (0 = unknown), blank and
// frozen frames, the one-line summary and the tally of a stream; that the core estimator
// flags a calibration of another size than its images (FrameInput::calibration_size); and that
// the LiDAR check measures the same on any thread count.
#include <string>

#include <opencv2/core.hpp>

#include "pipeline/estimator.hpp"
#include "quality/input_quality.hpp"
#include "synth/scene.hpp"
// cmocka 1.1.5's header lacks extern "C" and its fail() macro breaks <ios>: include it last.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "synth_fields.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::quality;

namespace {

void calibration_size(void **) {
    assert_true(calibration_size_mismatch({1242, 375}, {1242, 375}).empty());
    assert_true(calibration_size_mismatch({0, 0}, {1001, 333}).empty());     // unknown calibration size
    assert_true(calibration_size_mismatch({1242, 375}, {0, 0}).empty());     // unknown image size
    assert_true(calibration_size_mismatch({1242, 0}, {1001, 333}).empty());  // half known is unknown
    assert_string_equal(calibration_size_mismatch({1242, 375}, {1001, 333}).c_str(),
                        "the calibration is for 1242x375 images, these are 1001x333");
}

Input frame(const cv::Mat &l0, const cv::Mat &r0, const cv::Mat &l1, const cv::Mat &r1) {
    Input in;
    in.left0 = l0;
    in.right0 = r0;
    in.left1 = l1;
    in.right1 = r1;
    return in;
}

void blank_and_frozen(void **) {
    cv::Mat noise(48, 64, CV_8UC3);
    cv::randu(noise, 0, 255);
    cv::Mat other = noise.clone();
    other.at<cv::Vec3b>(0, 0)[0] ^= 1;
    const cv::Mat black = cv::Mat::zeros(48, 64, CV_8UC3), white(48, 64, CV_8UC3, cv::Scalar::all(255)),
                  gray(48, 64, CV_8UC3, cv::Scalar::all(128));
    assert_true(blank_frame(frame(noise, noise, other, noise)).empty());  // one pixel changed: not frozen
    assert_true(blank_frame(frame(noise, noise, noise, noise)).find("frozen") != std::string::npos);
    assert_true(blank_frame(frame(noise, white, noise, noise)).find("right0 is saturated") != std::string::npos);
    assert_true(blank_frame(frame(noise, noise, gray, noise)).find("left1 is uniform") != std::string::npos);
    assert_true(blank_frame(frame(noise, noise, noise, black)).find("right1 is black") != std::string::npos);
}

void summary_and_tally(void **) {
    Report r;
    assert_string_equal(r.summary().c_str(), "ok");
    r.add(LidarDisagrees, "b");
    r.add(LeftRightSwapped, "a");
    assert_int_equal(r.flags, LidarDisagrees | LeftRightSwapped);
    assert_string_equal(r.summary().c_str(), "left_right_swapped, lidar_disagrees (b; a)");
    assert_string_equal(flag_name(NotRectified), "not_rectified");
    assert_string_equal(flag_name(3), "unknown");
    Tally t;
    assert_string_equal(t.text().c_str(), "0 ok");
    t.add(0);
    t.add(0);
    t.add(BlankFrame);
    t.add(BlankFrame | CalibrationSizeMismatch);
    assert_string_equal(t.text().c_str(), "2 ok, 1 calibration_size_mismatch, 2 blank_frame");
}

// The estimator reports the calibration's size when it knows it, and only then.
void estimator_calibration_size(void **) {
    const synth::SynthScene s = test::render_scene(320, 96, 5);
    pipeline::EstimatorOptions o = pipeline::EstimatorOptions::preset("realtime");
    o.last_stage = pipeline::Stage::Matching;
    const pipeline::Estimator e(o);
    pipeline::FrameInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, {}};
    const pipeline::EstimatorResult known_nothing = e.run(in);
    if (!known_nothing.quality.ok()) fail_msg("%s", known_nothing.quality.summary().c_str());
    in.calibration_size = s.left0.size();
    assert_true(e.run(in).quality.ok());
    in.calibration_size = {s.left0.cols * 2, s.left0.rows * 2};
    const pipeline::EstimatorResult flagged = e.run(in);
    assert_int_equal(flagged.quality.flags, CalibrationSizeMismatch);
    // The same result, its confidence dropped: a flagged input is less to be trusted everywhere.
    in.calibration_size = s.left0.size();
    const pipeline::EstimatorResult good = e.run(in);
    assert_true(cv::norm(flagged.forward.u, good.forward.u, cv::NORM_INF) == 0);
    assert_true(cv::countNonZero(good.forward.confidence) > 0);
    assert_true(cv::norm(flagged.forward.confidence, good.forward.confidence * 0.25f, cv::NORM_INF) < 1e-6);
}

// A stream's first frame prepared ahead (Estimator::prepare_first) gives its pair the input
// checks of the pair alone, flagged or not; a frame prepared that is not the pair's t0 lends it
// nothing.
void prepared_first_frame(void **) {
    const synth::SynthScene s = test::render_scene(640, 192, 3);
    pipeline::EstimatorOptions o = pipeline::EstimatorOptions::preset("realtime");
    o.threads = 2;
    const pipeline::Estimator e(o);
    const pipeline::FrameInput good{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, s.left0.size()};
    const pipeline::FrameInput swapped{s.right0, s.left0, s.right1, s.left1, s.lidar0, s.lidar1, s.camera, {}};
    pipeline::FrameInput resized = good;
    resized.calibration_size = {s.left0.cols + 2, s.left0.rows};
    const pipeline::FrameInput *cases[] = {&good, &swapped, &resized};
    for (const pipeline::FrameInput *in : cases) {
        const pipeline::EstimatorResult alone = e.run(*in);
        pipeline::StreamCache cache;
        e.prepare_first(in->left0, in->right0, in->lidar0, cache);
        const pipeline::EstimatorResult prepared = e.run(*in, &cache);
        assert_true(cache.last_prepared());
        assert_int_equal(prepared.quality.flags, alone.quality.flags);
        assert_string_equal(prepared.quality.reason.c_str(), alone.quality.reason.c_str());
        assert_true(cv::norm(prepared.dense.d0, alone.dense.d0, cv::NORM_INF) == 0);
        assert_true(cv::norm(prepared.dense.confidence, alone.dense.confidence, cv::NORM_INF) == 0);
    }
    assert_true(e.run(good).quality.ok());
    assert_true(e.run(swapped).quality.flags & LeftRightSwapped);
    // The swapped frame prepared, the good pair run: nothing of it is taken, the pair is ok.
    pipeline::StreamCache cache;
    e.prepare_first(swapped.left0, swapped.right0, swapped.lidar0, cache);
    assert_true(e.run(good, &cache).quality.ok());
    assert_false(cache.last_prepared());
}

// The LiDAR check's measurement is the same on any thread count, and on a rendered scene with its
// exact LiDAR it decides points and finds them in agreement.
void lidar_agreement_on_threads(void **) {
    const synth::SynthScene s = test::render_scene(640, 192, 5);
    const StereoCheck one = check_stereo(s.left0, s.right0, &s.lidar0, 1);
    const StereoCheck three = check_stereo(s.left0, s.right0, &s.lidar0, 3);
    assert_true(one.lidar.decided > 0);
    assert_int_equal(three.lidar.decided, one.lidar.decided);
    assert_true(three.lidar.residual_p75 == one.lidar.residual_p75);
    assert_true(one.lidar_disagrees.empty());
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(calibration_size),
        cmocka_unit_test(blank_and_frozen),
        cmocka_unit_test(summary_and_tally),
        cmocka_unit_test(estimator_calibration_size),
        cmocka_unit_test(prepared_first_frame),
        cmocka_unit_test(lidar_agreement_on_threads),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
