// SPDX-License-Identifier: MIT
// core/maps.hpp: filled() gives the matrix OpenCV's fill constructor gives, byte for byte, for
// the element types the stages fill (invalid disparities, infinities, NaN vectors, negative
// labels and 16-bit disparities), at odd sizes and empty.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "core/maps.hpp"
#include "test_support.hpp"

using lidarflow::filled;

namespace {

template <class T>
void expect_same(int rows, int cols, const T &value) {
    const cv::Mat_<T> got = filled(rows, cols, value), want(rows, cols, value);
    assert_int_equal(got.rows, rows);
    assert_int_equal(got.cols, cols);
    assert_int_equal(got.type(), want.type());
    assert_true(got.isContinuous());
    if (rows * cols > 0) assert_int_equal(std::memcmp(got.data, want.data, got.total() * got.elemSize()), 0);
    const cv::Mat_<T> by_size = filled(cv::Size(cols, rows), value);
    assert_int_equal(by_size.rows, rows);
    assert_int_equal(by_size.cols, cols);
    if (rows * cols > 0) assert_int_equal(std::memcmp(by_size.data, want.data, got.total() * got.elemSize()), 0);
}

void filled_equals_the_fill_constructor(void **) {
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (auto [rows, cols] : {std::pair{206, 683}, {1, 1}, {3, 7}, {0, 5}}) {
        expect_same(rows, cols, lidarflow::kInvalidDisparity);
        expect_same(rows, cols, inf);
        expect_same(rows, cols, -16.25f);
        expect_same(rows, cols, -1);
        expect_same(rows, cols, static_cast<int16_t>(-16));
        expect_same(rows, cols, uint8_t{255});
        expect_same(rows, cols, cv::Vec3f(nan, nan, nan));
        expect_same(rows, cols, cv::Vec3f(1.5f, -2.0f, 3.25f));
        expect_same(rows, cols, cv::Vec2i(-1, 7));
    }
    const cv::Mat1f m = filled(2, 3, nan);
    for (float v : m) assert_true(std::isnan(v));
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(filled_equals_the_fill_constructor),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
