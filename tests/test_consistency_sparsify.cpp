// SPDX-License-Identifier: MIT
// Stage 3's sparsification on random fields against a direct statement of its rule (per block:
// every valid LiDAR pixel, plus the valid non-LiDAR pixel of the least support-window mean of
// the error, ties to the higher confidence, then the first in raster order), on 1, 2, 3, 7 and
// 64 threads, bit for bit; tied errors and cut border blocks included; NaN in the error refused.
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "consistency/sparsify.hpp"
#include "consistency_fixtures.hpp"  // last: brings cmocka

using namespace lidarflow;
using namespace lidarflow::consistency;

namespace {

constexpr int W = 53, H = 38;  // neither a multiple of the 3 px blocks: cut border blocks

struct Case {
    SceneFlowField field = SceneFlowField::zeros(W, H);
    cv::Mat1f error = cv::Mat1f(H, W, 0.0f);
    LidarReference lidar;
};

// Valid matches on ~70 % of the pixels, errors on a coarse grid of values (many ties), some
// +inf (unmeasured round trips), confidences in two levels, ~2 % LiDAR pixels.
Case random_case(unsigned seed) {
    std::mt19937 gen(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    Case c;
    SparseLidar points{W, H, {}};
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            if (unit(gen) < 0.7f) {
                test::set_match(c.field, x, y, unit(gen) * 4 - 2, unit(gen) * 2 - 1, 5 + unit(gen) * 20, 5 + unit(gen) * 20);
                c.field.confidence(y, x) = unit(gen) < 0.5f ? 0.5f : 1.0f;
            }
            const float r = unit(gen);
            c.error(y, x) = r < 0.05f ? std::numeric_limits<float>::infinity() : std::floor(r * 8.0f) * 0.25f;
            if (unit(gen) < 0.02f) points.points.push_back({x, y, 5 + unit(gen) * 20});
        }
    c.lidar = LidarReference::build(points, W, H, 15);
    return c;
}

ConsistencyOptions options(int threads) {
    ConsistencyOptions o;
    o.threads = threads;
    return o;
}

// The rule of sparsify.hpp, written out one pixel at a time.
cv::Mat1b reference_keep(const Case &c, const ConsistencyOptions &o) {
    cv::Mat1f score(H, W);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const float e = c.error(y, x);
            score(y, x) = !c.field.valid(y, x) ? o.sparsify_missing_error
                          : std::isfinite(e)  ? e
                                              : o.sparsify_missing_error;
        }
    cv::blur(score, score, {o.sparsify_support, o.sparsify_support}, {-1, -1}, cv::BORDER_REPLICATE);
    cv::Mat1b keep(H, W, uchar(0));
    const int b = o.sparsify_block;
    for (int by = 0; by < H; by += b)
        for (int bx = 0; bx < W; bx += b) {
            int bestx = -1, besty = -1;
            for (int y = by; y < std::min(H, by + b); ++y)
                for (int x = bx; x < std::min(W, bx + b); ++x) {
                    if (!c.field.valid(y, x)) continue;
                    if (c.lidar.is_lidar(y, x)) {
                        keep(y, x) = 1;
                        continue;
                    }
                    const bool better = bestx < 0 || score(y, x) < score(besty, bestx) ||
                                        (score(y, x) == score(besty, bestx) &&
                                         c.field.confidence(y, x) > c.field.confidence(besty, bestx));
                    if (better) {
                        bestx = x;
                        besty = y;
                    }
                }
            if (bestx >= 0) keep(besty, bestx) = 1;
        }
    return keep;
}

bool same_field(const SceneFlowField &a, const SceneFlowField &b) {
    const cv::Mat *pa[] = {&a.u, &a.v, &a.d0, &a.d1, &a.valid, &a.confidence};
    const cv::Mat *pb[] = {&b.u, &b.v, &b.d0, &b.d1, &b.valid, &b.confidence};
    for (int i = 0; i < 6; ++i) {
        const size_t bytes = pa[i]->total() * pa[i]->elemSize();
        if (pa[i]->size() != pb[i]->size() || std::memcmp(pa[i]->data, pb[i]->data, bytes) != 0) return false;
    }
    return true;
}

void keeps_the_rules_pixels_on_any_thread_count(void **) {
    int kept = 0;
    for (unsigned seed = 1; seed <= 6; ++seed) {
        const Case c = random_case(seed);
        const SceneFlowField one = sparsify(c.field, c.error, c.lidar, options(1));
        const cv::Mat1b want = reference_keep(c, options(1));
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                assert_int_equal(one.valid(y, x), want(y, x));
                if (want(y, x)) {
                    assert_true(one.u(y, x) == c.field.u(y, x) && one.d1(y, x) == c.field.d1(y, x));
                    ++kept;
                }
            }
        for (int t : {2, 3, 7, 64}) assert_true(same_field(sparsify(c.field, c.error, c.lidar, options(t)), one));
    }
    assert_true(kept > 6 * (W / 3) * (H / 3) / 2);  // most blocks keep a match
}

void nan_in_the_error_is_refused(void **) {
    Case c = random_case(9);
    c.error(H - 1, W - 1) = std::numeric_limits<float>::quiet_NaN();
    for (int t : {1, 2, 7})
        test::expect_error([&] { sparsify(c.field, c.error, c.lidar, options(t)); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(keeps_the_rules_pixels_on_any_thread_count),
        cmocka_unit_test(nan_in_the_error_is_refused),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
