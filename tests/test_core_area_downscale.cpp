// SPDX-License-Identifier: MIT
// core/area_downscale.hpp: the same bytes as cv::resize(INTER_AREA) on fractional and integer
// ratios, 1 to 4 channels, odd sizes, any thread count, the KITTI frames at the presets' scales
// (when LIDARFLOW_KITTI_DIR is set), and clear refusals.
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/area_downscale.hpp"
#include "core/error.hpp"
#include "pipeline/resolution.hpp"
#include "test_support.hpp"

using namespace lidarflow;

namespace {

// Fails with the first differing position unless our reduction of `src` equals OpenCV's.
void expect_same_as_opencv(const cv::Mat &src, cv::Size size, int threads) {
    cv::Mat ours, theirs;
    area_downscale(src, ours, size, threads);
    cv::resize(src, theirs, size, 0, 0, cv::INTER_AREA);
    assert_int_equal(ours.type(), theirs.type());
    assert_true(ours.size() == theirs.size());
    cv::Mat diff;
    cv::absdiff(ours.reshape(1), theirs.reshape(1), diff);
    cv::Point at;
    double worst = 0;
    cv::minMaxLoc(diff, nullptr, &worst, nullptr, &at);
    if (worst != 0)
        fail_msg("%dx%d (%d channels) -> %dx%d on %d thread(s): differs by %.0f at (%d, %d)", src.cols, src.rows,
                 src.channels(), size.width, size.height, threads, worst, at.x, at.y);
}

cv::Mat noise(int w, int h, int type, uint64_t seed) {
    cv::Mat m(h, w, type);
    cv::RNG rng(seed);
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    return m;
}

void random_images_match_opencv(void **) {
    const int types[] = {CV_8UC1, CV_8UC2, CV_8UC3, CV_8UC4};
    const struct {
        int w, h, ow, oh;
    } cases[] = {{1242, 375, 683, 206}, {1242, 375, 807, 244}, {101, 37, 55, 20}, {64, 48, 63, 47},
                 {640, 192, 352, 106}, {99, 99, 10, 3},      {17, 5, 1, 1},     {30, 20, 30, 7},
                 {60, 40, 20, 10} /* integer ratios: OpenCV's own */};
    uint64_t seed = 1;
    for (int type : types)
        for (const auto &c : cases)
            for (int threads : {1, 2, 3}) expect_same_as_opencv(noise(c.w, c.h, type, seed++), {c.ow, c.oh}, threads);
}

void smooth_images_match_opencv(void **) {
    // Noise rarely lands a sum on a rounding boundary; flat areas and gradients do, often.
    cv::Mat ramp(375, 1242, CV_8UC3);
    for (int y = 0; y < ramp.rows; ++y)
        for (int x = 0; x < ramp.cols; ++x)
            ramp.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uint8_t>(x / 5), static_cast<uint8_t>(y / 2),
                                                 static_cast<uint8_t>((x + y) % 7 == 0 ? 255 : 128));
    for (double scale : {0.55, 0.65, 0.5 + 1e-3, 0.9, 0.3})
        expect_same_as_opencv(ramp, pipeline::scaled_size(ramp.cols, ramp.rows, scale), 2);
    const cv::Mat flat(37, 53, CV_8UC1, cv::Scalar(77));
    expect_same_as_opencv(flat, {29, 20}, 2);
}

void a_view_into_a_larger_image_matches(void **) {
    const cv::Mat big = noise(300, 200, CV_8UC3, 7);
    const cv::Mat view = big(cv::Rect(13, 9, 211, 151));
    expect_same_as_opencv(view, {116, 83}, 2);
    cv::Mat inplace = view.clone(), expected;
    cv::resize(inplace, expected, {116, 83}, 0, 0, cv::INTER_AREA);
    area_downscale(inplace, inplace, {116, 83}, 2);  // dst may be src
    assert_int_equal(cv::norm(inplace, expected, cv::NORM_INF), 0);
}

void kitti_frames_match_opencv(void **) {
    const std::string root = test::kitti_dir();
    if (root.empty()) {
        std::printf("kitti_frames_match_opencv: skipped (LIDARFLOW_KITTI_DIR not set)\n");
        return;
    }
    for (const char *id : {"000002", "000003"})
        for (const char *folder : {"image_2", "image_3"}) {
            const cv::Mat image = cv::imread(root + "/" + folder + "/" + id + "_10.png", cv::IMREAD_UNCHANGED);
            assert_false(image.empty());
            for (double scale : {0.55, 0.65})  // realtime; default and fast
                expect_same_as_opencv(image, pipeline::scaled_size(image.cols, image.rows, scale), 2);
        }
}

void refuses_bad_arguments(void **) {
    const cv::Mat img = noise(20, 10, CV_8UC1, 3);
    cv::Mat out;
    test::expect_error([&] { area_downscale(cv::Mat(), out, {2, 2}, 1); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { area_downscale(img, out, {0, 2}, 1); }, ErrorCode::InvalidArgument);
    test::expect_error([&] { area_downscale(img, out, {2, 2}, 0); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(random_images_match_opencv),
        cmocka_unit_test(smooth_images_match_opencv),
        cmocka_unit_test(a_view_into_a_larger_image_matches),
        cmocka_unit_test(kitti_frames_match_opencv),
        cmocka_unit_test(refuses_bad_arguments),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
