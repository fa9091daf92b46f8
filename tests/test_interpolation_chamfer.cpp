// SPDX-License-Identifier: MIT
// interpolation/chamfer_distance.hpp: ChamferMask3::near gives, bit for bit, what
// cv::distanceTransform(DIST_L2, 3) gives at a pixel whenever a zero pixel lies within the
// reach, on random maps of several densities, sizes and at the image's edges; reach_below
// bounds every zero pixel closer than a limit.
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include <opencv2/imgproc.hpp>

#include "interpolation/chamfer_distance.hpp"
#include "test_support.hpp"

using lidarflow::interpolation::ChamferMask3;

namespace {

void near_equals_the_distance_transform(void **) {
    std::mt19937 gen(21);
    int compared = 0, none = 0;
    for (const cv::Size size : {cv::Size(97, 61), cv::Size(1, 40), cv::Size(33, 1), cv::Size(200, 120)})
        for (const double density : {0.002, 0.02, 0.2}) {
            cv::Mat1b mask(size, uchar{255});
            std::bernoulli_distribution zero(density);
            for (uchar &v : mask) v = zero(gen) ? 0 : 255;
            mask(gen() % size.height, gen() % size.width) = 0;  // at least one
            cv::Mat1f want;
            cv::distanceTransform(mask, want, cv::DIST_L2, 3);
            for (const int reach : {0, 1, 3, 5, 12})
                for (int y = 0; y < size.height; ++y)
                    for (int x = 0; x < size.width; ++x) {
                        const float got = ChamferMask3::near(mask, x, y, reach);
                        // Within the reach the window holds the nearest zero pixel whenever its
                        // distance is below the reach's bound.
                        const float bound = (reach + 1) * 0.955f;
                        if (want(y, x) < bound - 1e-3f) {
                            uint32_t a, b;
                            std::memcpy(&a, &got, sizeof a);
                            std::memcpy(&b, &want(y, x), sizeof b);
                            if (a != b) {
                                std::printf("(%d, %d) reach %d: %.9g, OpenCV %.9g\n", x, y, reach,
                                            static_cast<double>(got), static_cast<double>(want(y, x)));
                                fail();
                            }
                            ++compared;
                        } else {
                            assert_true(got >= want(y, x));  // a farther one, or none (+inf)
                            none += std::isinf(got);
                        }
                    }
        }
    assert_true(compared > 50000);
    assert_true(none > 1000);
}

void reach_bounds_the_limit(void **) {
    for (const float limit : {0.0f, 0.5f, 0.955f, 1.0f, 4.0f, 4.5f, 10.0f, 100.0f}) {
        const int r = ChamferMask3::reach_below(limit);
        // A zero pixel r + 1 along an axis is at least that far, whatever its other offset.
        assert_true(static_cast<float>(ChamferMask3::kStraight * static_cast<uint64_t>(r + 1)) * ChamferMask3::kScale >=
                    limit);
    }
    const int far = ChamferMask3::reach_below(1e30f);  // beyond any image, without overflow
    assert_true(far >= 1000000 && far <= (1 << 20));
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(near_equals_the_distance_transform),
        cmocka_unit_test(reach_bounds_the_limit),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
