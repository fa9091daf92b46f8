// SPDX-License-Identifier: MIT
// flow/dis.hpp: OpenCV's DISOpticalFlow bit for bit (no variational refinement) at the presets'
// settings and others (patch 6 and 8, strides 2-4, finest level 0 and 1, with and without an
// initial flow, odd sizes, 1-3 threads), on textured images with a known motion and on the
// KITTI frames (when LIDARFLOW_KITTI_DIR is set); the motion recovered; clear refusals.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "core/error.hpp"
#include "flow/dis.hpp"
#include "pipeline/resolution.hpp"
#include "test_support.hpp"

using namespace lidarflow;

namespace {

cv::Mat2f opencv_flow(const cv::Mat &a, const cv::Mat &b, const flow::DisOptions &o, const cv::Mat2f &initial) {
    cv::Ptr<cv::DISOpticalFlow> dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
    dis->setFinestScale(o.finest_scale);
    dis->setPatchSize(o.patch_size);
    dis->setPatchStride(o.patch_stride);
    dis->setGradientDescentIterations(o.descent_iterations);
    dis->setVariationalRefinementIterations(0);
    cv::Mat2f flow = initial.clone();
    dis->calc(a, b, flow);
    return flow;
}

// Fails with the first differing value unless our flow equals OpenCV's exactly.
void expect_same_as_opencv(const cv::Mat &a, const cv::Mat &b, const flow::DisOptions &o,
                           const cv::Mat2f &initial = cv::Mat2f()) {
    const cv::Mat2f ours = flow::dis_flow(a, b, o, initial), theirs = opencv_flow(a, b, o, initial);
    assert_true(ours.size() == theirs.size());
    for (int y = 0; y < ours.rows; ++y)
        for (int x = 0; x < ours.cols; ++x)
            for (int c = 0; c < 2; ++c)
                if (ours(y, x)[c] != theirs(y, x)[c])  // exact: not even the last bit may differ
                    fail_msg("%dx%d, patch %d stride %d, %d steps, finest %d, %s initial flow, %d thread(s): "
                             "(%d, %d)[%d] is %.9g, OpenCV's %.9g",
                             a.cols, a.rows, o.patch_size, o.patch_stride, o.descent_iterations, o.finest_scale,
                             initial.empty() ? "no" : "an", o.threads, x, y, c, ours(y, x)[c], theirs(y, x)[c]);
}

// Smooth random texture (what DIS can track), 8-bit gray.
cv::Mat texture(int w, int h, uint64_t seed) {
    cv::Mat1f f(h, w);
    cv::RNG rng(seed);
    rng.fill(f, cv::RNG::UNIFORM, 0.0, 255.0);
    cv::GaussianBlur(f, f, cv::Size(0, 0), 1.5);
    cv::Mat g;
    cv::normalize(f, f, 0, 255, cv::NORM_MINMAX);
    f.convertTo(g, CV_8U);
    return g;
}

// `image` moved by a smooth motion (u, v) = (du + 0.01 x, dv - 0.005 y): the second frame.
cv::Mat moved(const cv::Mat &image, float du, float dv) {
    cv::Mat1f mx(image.size()), my(image.size());
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
            mx(y, x) = static_cast<float>(x) - (du + 0.01f * static_cast<float>(x));
            my(y, x) = static_cast<float>(y) - (dv - 0.005f * static_cast<float>(y));
        }
    cv::Mat out;
    cv::remap(image, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REFLECT);
    return out;
}

cv::Mat2f smooth_initial(cv::Size s, float du, float dv) {
    cv::Mat2f f(s);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            f(y, x) = cv::Vec2f(du + 0.008f * static_cast<float>(x), dv + 0.3f * std::sin(0.05f * static_cast<float>(y)));
    return f;
}

void textured_images_match_opencv(void **) {
    const struct {
        int w, h;
    } sizes[] = {{683, 206}, {211, 97}, {160, 64}, {97, 211}};
    const struct {
        int patch, stride, steps, finest;
    } settings[] = {{8, 3, 16, 0}, {8, 4, 16, 0}, {6, 2, 25, 0}, {6, 3, 25, 0}, {8, 3, 25, 1}, {5, 2, 7, 0}, {12, 5, 10, 0}};
    uint64_t seed = 11;
    for (const auto &s : sizes) {
        const cv::Mat a = texture(s.w, s.h, seed++), b = moved(a, 3.3f, -1.7f);
        for (const auto &p : settings) {
            flow::DisOptions o;
            o.patch_size = p.patch, o.patch_stride = p.stride, o.descent_iterations = p.steps;
            o.finest_scale = p.finest;
            if (flow::dis_coarsest_scale(a.size(), o.patch_size) < o.finest_scale) continue;
            for (int threads : {1, 2, 3}) {
                o.threads = threads;
                expect_same_as_opencv(a, b, o);
                if (threads == 2) expect_same_as_opencv(a, b, o, smooth_initial(a.size(), 2.5f, -1.0f));
            }
        }
    }
}

void recovers_a_known_motion(void **) {
    const cv::Mat a = texture(320, 160, 5), b = moved(a, 4.25f, -2.5f);
    flow::DisOptions o;
    o.patch_size = 8, o.patch_stride = 3, o.threads = 2;
    const cv::Mat2f f = flow::dis_flow(a, b, o);
    std::vector<float> eu, ev;
    for (int y = 20; y < f.rows - 20; ++y)
        for (int x = 20; x < f.cols - 20; ++x) {
            eu.push_back(std::abs(f(y, x)[0] - (4.25f + 0.01f * static_cast<float>(x))));
            ev.push_back(std::abs(f(y, x)[1] - (-2.5f - 0.005f * static_cast<float>(y))));
        }
    std::nth_element(eu.begin(), eu.begin() + eu.size() / 2, eu.end());
    std::nth_element(ev.begin(), ev.begin() + ev.size() / 2, ev.end());
    // Interior median errors of a clean sub-pixel motion: well under a tenth of a pixel.
    assert_true(eu[eu.size() / 2] < 0.1f);
    assert_true(ev[ev.size() / 2] < 0.1f);
}

void kitti_frames_match_opencv(void **) {
    const std::string root = test::kitti_dir();
    if (root.empty()) {
        std::printf("kitti_frames_match_opencv: skipped (LIDARFLOW_KITTI_DIR not set)\n");
        return;
    }
    for (const char *id : {"000002", "000003"}) {
        const cv::Mat full0 = cv::imread(root + "/image_2/" + id + "_10.png", cv::IMREAD_GRAYSCALE);
        const cv::Mat full1 = cv::imread(root + "/image_2/" + id + "_11.png", cv::IMREAD_GRAYSCALE);
        assert_false(full0.empty() || full1.empty());
        // realtime (0.55, patch 8, strides 3 and 4, 16 steps); fast and default (0.65, patch 6).
        const struct {
            double scale;
            int patch, stride, steps;
        } presets[] = {{0.55, 8, 3, 16}, {0.55, 8, 4, 16}, {0.65, 6, 2, 25}, {0.65, 6, 3, 25}};
        for (const auto &p : presets) {
            cv::Mat a, b;
            const cv::Size s = pipeline::scaled_size(full0.cols, full0.rows, p.scale);
            cv::resize(full0, a, s, 0, 0, cv::INTER_AREA);
            cv::resize(full1, b, s, 0, 0, cv::INTER_AREA);
            flow::DisOptions o;
            o.patch_size = p.patch, o.patch_stride = p.stride, o.descent_iterations = p.steps, o.threads = 2;
            expect_same_as_opencv(a, b, o);
            expect_same_as_opencv(b, a, o, smooth_initial(a.size(), -1.0f, 0.5f));
        }
    }
}

void refuses_bad_arguments(void **) {
    const cv::Mat a = texture(64, 48, 1), b = texture(64, 48, 2);
    const flow::DisOptions ok;
    test::expect_error([&] { flow::dis_flow(cv::Mat(), b, ok); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { flow::dis_flow(a, texture(63, 48, 2), ok); }, ErrorCode::SizeMismatch);
    cv::Mat color;
    cv::cvtColor(a, color, cv::COLOR_GRAY2BGR);
    test::expect_error([&] { flow::dis_flow(color, color, ok); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { flow::dis_flow(a, b, ok, cv::Mat2f(10, 10)); }, ErrorCode::SizeMismatch);
    for (auto bad : {+[](flow::DisOptions &o) { o.patch_size = 1; }, +[](flow::DisOptions &o) { o.patch_stride = 0; },
                     +[](flow::DisOptions &o) { o.patch_stride = 9; }, +[](flow::DisOptions &o) { o.threads = 0; },
                     +[](flow::DisOptions &o) { o.descent_iterations = -1; },
                     +[](flow::DisOptions &o) { o.finest_scale = 11; }}) {
        flow::DisOptions o;
        bad(o);
        test::expect_error([&] { flow::dis_flow(a, b, o); }, ErrorCode::InvalidArgument);
    }
    // Too small for a level at the finest scale asked.
    flow::DisOptions deep;
    deep.finest_scale = 3;
    test::expect_error([&] { flow::dis_flow(a, b, deep); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { flow::dis_flow(texture(6, 6, 3), texture(6, 6, 4), ok); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(textured_images_match_opencv),
        cmocka_unit_test(recovers_a_known_motion),
        cmocka_unit_test(kitti_frames_match_opencv),
        cmocka_unit_test(refuses_bad_arguments),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
