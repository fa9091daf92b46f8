// SPDX-License-Identifier: MIT
// compute_superpixels with a disparity map: on an image whose colours show nothing of a depth
// step (one random texture across it), the superpixels end at the step when the disparity
// weighs in, and straddle it when only colour does;
//  - a map with no valid pixel, an empty map or a zero weight give the colour-only segmentation;
//  - the result is the same on any thread count; bad arguments are refused.
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "interpolation/superpixels.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::interpolation;

namespace {

constexpr int kW = 200, kH = 90, kStep = 100;  // the step halves a grid cell (13 of 15.4 px)

cv::Mat texture() {
    cv::Mat image(kH, kW, CV_8UC3);
    cv::setRNGSeed(11);
    cv::randu(image, cv::Scalar::all(90), cv::Scalar::all(170));
    cv::GaussianBlur(image, image, cv::Size(5, 5), 0);
    return image;
}

// Disparity 12 px left of the step, 30 px right of it; every fifth row invalid (as the stereo
// leaves holes).
cv::Mat1f step_disparity() {
    cv::Mat1f d(kH, kW);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) d(y, x) = y % 5 == 4 ? -1.0f : x < kStep ? 12.0f : 30.0f;
    return d;
}

SuperpixelOptions options(float weight, int threads = 1) {
    SuperpixelOptions o;
    o.region_size = 16;
    o.disparity_weight = weight;
    o.num_threads = threads;
    return o;
}

// Pixels with a disparity in superpixels on the minority side of the step, summed over the
// superpixels (those without one take their superpixel from colour and place alone).
int straddling(const Superpixels &sp, const cv::Mat1f &d) {
    std::vector<int> left(sp.count, 0), right(sp.count, 0);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
            if (d(y, x) >= 0) ++(x < kStep ? left : right)[sp.labels(y, x)];
    int n = 0;
    for (int l = 0; l < sp.count; ++l) n += std::min(left[l], right[l]);
    return n;
}

bool same_labels(const Superpixels &a, const Superpixels &b) {
    return a.count == b.count && cv::countNonZero(a.labels != b.labels) == 0;
}

void superpixels_end_at_the_depth_step(void **) {
    const cv::Mat image = texture();
    const cv::Mat1f d = step_disparity();
    const Superpixels colour = compute_superpixels(image, options(0.0f), d);
    const Superpixels depth = compute_superpixels(image, options(64.0f), d);
    std::printf("pixels across the step: colour only %d, with depth %d\n", straddling(colour, d), straddling(depth, d));
    assert_true(straddling(colour, d) > 300);  // the grid column around x = 100 straddles it
    assert_int_equal(straddling(depth, d), 0);
    // A comparable number of superpixels: the term moves boundaries, it does not split cells.
    assert_true(std::abs(depth.count - colour.count) <= colour.count / 5);
}

void no_disparity_is_colour_only(void **) {
    const cv::Mat image = texture();
    const Superpixels colour = compute_superpixels(image, options(0.0f));
    assert_true(same_labels(compute_superpixels(image, options(64.0f)), colour));  // no map
    cv::Mat1f invalid(kH, kW, -1.0f);
    invalid(3, 3) = std::numeric_limits<float>::quiet_NaN();
    invalid(5, 9) = std::numeric_limits<float>::infinity();
    assert_true(same_labels(compute_superpixels(image, options(64.0f), invalid), colour));
    assert_true(same_labels(compute_superpixels(image, options(0.0f), step_disparity()), colour));
}

void same_on_any_thread_count(void **) {
    const cv::Mat image = texture();
    const cv::Mat1f d = step_disparity();
    const Superpixels one = compute_superpixels(image, options(64.0f, 1), d);
    for (int t : {2, 3, 7, 64}) assert_true(same_labels(compute_superpixels(image, options(64.0f, t), d), one));
}

void rejects_bad_arguments(void **) {
    const cv::Mat image = texture();
    const cv::Mat1f d = step_disparity();
    test::expect_error([&] { compute_superpixels(image, options(64.0f), cv::Mat1f(kH - 1, kW, 1.0f)); },
                       ErrorCode::InvalidArgument);
    for (float bad : {-1.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), 2e4f})
        test::expect_error([&] { compute_superpixels(image, options(bad), d); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(superpixels_end_at_the_depth_step),
        cmocka_unit_test(no_disparity_is_colour_only),
        cmocka_unit_test(same_on_any_thread_count),
        cmocka_unit_test(rejects_bad_arguments),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
