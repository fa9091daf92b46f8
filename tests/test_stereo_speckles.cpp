// SPDX-License-Identifier: MIT
// stereo/speckles.hpp: filter_speckles leaves a CV_16S disparity map exactly as
// cv::filterSpeckles does, on maps of random blobs and noise (regions of many sizes, values
// near the difference bound, invalid pixels, regions across the bands' borders), several sizes,
// bounds and thread counts.
#include <cstring>
#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "stereo/speckles.hpp"
#include "test_support.hpp"

using lidarflow::test::expect_error;
using lidarflow::stereo::filter_speckles;

namespace {

cv::Mat1s random_disparities(std::mt19937 &gen, cv::Size size) {
    cv::Mat1s d(size, int16_t{0});
    std::uniform_int_distribution<int> value(0, 64 * 16), px(0, size.width - 1), py(0, size.height - 1), r(1, 9);
    for (int b = 0; b < size.area() / 40; ++b)  // blobs of one value
        cv::circle(d, {px(gen), py(gen)}, r(gen), cv::Scalar(value(gen)), cv::FILLED);
    for (int16_t &v : d) {
        const unsigned k = gen() % 16;
        if (k == 0) v = -16;                                      // invalid
        else if (k == 1) v = static_cast<int16_t>(value(gen));  // noise
        else if (k == 2) v = static_cast<int16_t>(v + static_cast<int>(gen() % 33) - 16);  // near the bound
    }
    return d;
}

void equals_opencv(void **) {
    std::mt19937 gen(41);
    int compared = 0, changed = 0;
    for (const cv::Size size : {cv::Size(683, 206), cv::Size(97, 61), cv::Size(1, 50), cv::Size(40, 1)})
        for (int rep = 0; rep < 3; ++rep) {
            const cv::Mat1s d = random_disparities(gen, size);
            for (const int max_size : {0, 1, 20, 100, 400})
                for (const int max_diff : {0, 16, 32})
                    for (const int threads : {1, 2, 5}) {
                        cv::Mat1s want = d.clone(), got = d.clone();
                        cv::filterSpeckles(want, -16, max_size, max_diff);
                        filter_speckles(got, -16, max_size, max_diff, threads);
                        assert_int_equal(std::memcmp(want.data, got.data, want.total() * want.elemSize()), 0);
                        changed += cv::countNonZero(want != d) > 0;
                        ++compared;
                    }
        }
    assert_int_equal(compared, 4 * 3 * 5 * 3 * 3);
    assert_true(changed > 100);  // the filter removed something in most settings
}

void rejects_bad_arguments(void **) {
    cv::Mat1s d(4, 4, int16_t{16});
    expect_error([&] { filter_speckles(d, -16, 10, -1, 1); }, lidarflow::ErrorCode::InvalidArgument);
    cv::Mat1s empty;
    filter_speckles(empty, -16, 10, 16, 2);  // nothing to do
    assert_true(empty.empty());
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(equals_opencv),
        cmocka_unit_test(rejects_bad_arguments),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
