// SPDX-License-Identifier: MIT
// core/rounding.hpp: round_to_int is std::lround for every float a pixel coordinate can be (all
// half-way values, both signs, zeros, subnormals, the float grid's coarse range up to 2^30),
// saturates beyond, and maps NaN to 0.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>

#include "core/rounding.hpp"
#include "test_support.hpp"

using lidarflow::round_to_int;

namespace {

void expect_lround(float v) {
    if (std::lround(v) != round_to_int(v)) {
        std::printf("round_to_int(%.9g) = %d, lround %ld\n", static_cast<double>(v), round_to_int(v), std::lround(v));
        fail();
    }
}

void equals_lround(void **) {
    for (int k = -200000; k <= 200000; ++k) {  // every half and quarter step to +-50000
        expect_lround(static_cast<float>(k) * 0.25f);
        expect_lround(std::nextafter(static_cast<float>(k) * 0.25f, 0.0f));
        expect_lround(std::nextafter(static_cast<float>(k) * 0.25f, static_cast<float>(k)));
    }
    for (const float v : {0.0f, -0.0f, 0.49999997f, -0.49999997f, 0.5f, -0.5f, 8388607.5f, -8388607.5f, 8388608.0f,
                          16777215.0f, 16777216.0f, 16777218.0f, 1073741760.0f, -1073741760.0f,
                          std::numeric_limits<float>::denorm_min(), -std::numeric_limits<float>::min()})
        expect_lround(v);
    std::mt19937 rng(3);
    for (int i = 0; i < 2000000; ++i) {  // random bit patterns below 2^30 in magnitude
        uint32_t bits = static_cast<uint32_t>(rng());
        float v;
        std::memcpy(&v, &bits, sizeof v);
        if (!std::isfinite(v) || std::fabs(v) >= 1073741824.0f) continue;
        expect_lround(v);
    }
}

void saturates_and_maps_nan_to_zero(void **) {
    assert_int_equal(round_to_int(1073741824.0f), 1 << 30);
    assert_int_equal(round_to_int(3e9f), 1 << 30);
    assert_int_equal(round_to_int(-1e30f), -(1 << 30));
    assert_int_equal(round_to_int(std::numeric_limits<float>::infinity()), 1 << 30);
    assert_int_equal(round_to_int(-std::numeric_limits<float>::infinity()), -(1 << 30));
    assert_int_equal(round_to_int(std::numeric_limits<float>::quiet_NaN()), 0);
}

// nearest_inside: the rounded pixel, and whether it lies on a 4 x 3 image (-0.5 rounds off it).
void nearest_inside_rounds_and_bounds(void **) {
    int x = -9, y = -9;
    assert_true(lidarflow::nearest_inside(2.5f, -0.49f, 4, 3, x, y));
    assert_int_equal(x, 3);
    assert_int_equal(y, 0);
    assert_false(lidarflow::nearest_inside(-0.5f, 1.0f, 4, 3, x, y));
    assert_false(lidarflow::nearest_inside(3.5f, 1.0f, 4, 3, x, y));
    assert_false(lidarflow::nearest_inside(1.0f, 2.5f, 4, 3, x, y));
    assert_false(lidarflow::nearest_inside(std::numeric_limits<float>::quiet_NaN(), 1e30f, 4, 3, x, y));
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(equals_lround),
        cmocka_unit_test(saturates_and_maps_nan_to_zero),
        cmocka_unit_test(nearest_inside_rounds_and_bounds),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
