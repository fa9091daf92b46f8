// SPDX-License-Identifier: MIT
// The LiDAR residuals spread over the pixels of their model (lidar_residual_correction)
// against their definition evaluated pixel by pixel; the weights at the point, inside and at
// the radius; other models untouched; bad arguments rejected.
#include "test_support.hpp"

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "core/error.hpp"
#include "interpolation/lidar_residuals.hpp"

using namespace lidarflow;
using namespace lidarflow::interpolation;

namespace {

// The definition, for one pixel: every point, in order.
float brute(const cv::Mat1i &model_of, const std::vector<cv::Point> &pts, const std::vector<float> &res, float radius,
            float prior, int x, int y) {
    float sw = 0, swr = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
        const float dx = static_cast<float>(x - pts[i].x), dy = static_cast<float>(y - pts[i].y);
        const float d2 = dx * dx + dy * dy, r2 = radius * radius;
        if (d2 >= r2 || model_of(pts[i]) != model_of(y, x)) continue;
        const float q = 1.0f - d2 / r2;
        sw += q * q;
        swr += q * q * res[i];
    }
    return sw > 0 ? swr / (sw + prior) : 0.0f;
}

void equals_its_definition(void **) {
    std::mt19937 gen(7);
    const cv::Size size(97, 41);
    // Three models: two halves split by a slanted line and a block.
    cv::Mat1i model_of(size);
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x)
            model_of(y, x) = (x > 20 && x < 35 && y > 10 && y < 25) ? 2 : (x + y / 2 < 50 ? 0 : 1);
    std::uniform_int_distribution<int> px(0, size.width - 1), py(0, size.height - 1);
    std::uniform_real_distribution<float> rr(-3.0f, 3.0f);
    int touched = 0;
    for (int n : {0, 1, 30, 600}) {
        std::vector<cv::Point> pts;
        std::vector<float> res;
        cv::Mat1b used(size, 0);
        for (cv::Point p : {cv::Point(0, 0), cv::Point(size.width - 1, size.height - 1)})
            if (static_cast<int>(pts.size()) < n) used(p) = 1, pts.push_back(p), res.push_back(rr(gen));
        while (static_cast<int>(pts.size()) < n) {
            const cv::Point p(px(gen), py(gen));
            if (used(p)) continue;
            used(p) = 1;
            pts.push_back(p);
            res.push_back(rr(gen));
        }
        for (float radius : {0.0f, 1.0f, 2.5f, 3.0f, 6.0f}) {
            const cv::Mat1f c = lidar_residual_correction(model_of, pts, res, radius, 0.05f);
            assert_int_equal(c.rows, size.height);
            assert_int_equal(c.cols, size.width);
            // Bands of rows on any thread count: every pixel still adds its terms in point order.
            for (int threads : {2, 3, 7, 64}) {
                const cv::Mat1f ct = lidar_residual_correction(model_of, pts, res, radius, 0.05f, threads);
                assert_int_equal(std::memcmp(c.data, ct.data, c.total() * sizeof(float)), 0);
            }
            for (int y = 0; y < size.height; ++y)
                for (int x = 0; x < size.width; ++x) {
                    const float want = brute(model_of, pts, res, radius, 0.05f, x, y);
                    assert_true(std::fabs(c(y, x) - want) <= 1e-5f * (1.0f + std::fabs(want)));
                    touched += c(y, x) != 0.0f;
                }
        }
    }
    assert_true(touched > 1000);
}

void weights_and_models(void **) {
    cv::Mat1i model_of(21, 21, 0);
    model_of.colRange(13, 21).setTo(1);
    const std::vector<cv::Point> pts = {cv::Point(10, 10)};
    const std::vector<float> res = {2.0f};
    const cv::Mat1f c = lidar_residual_correction(model_of, pts, res, 4.0f, 0.25f);
    assert_float_equal(c(10, 10), 2.0f / 1.25f, 1e-6);            // on the point: weight 1
    const float w = (1.0f - 4.0f / 16.0f) * (1.0f - 4.0f / 16.0f);  // 2 px away
    assert_float_equal(c(10, 8), 2.0f * w / (w + 0.25f), 1e-6);
    assert_float_equal(c(10, 6), 0.0f, 0.0);   // at the radius: nothing
    assert_float_equal(c(10, 13), 0.0f, 0.0);  // 3 px away, but another model's pixel
    assert_float_equal(c(0, 0), 0.0f, 0.0);
    // Off: all zero.
    assert_int_equal(cv::countNonZero(lidar_residual_correction(model_of, pts, res, 0.0f, 0.25f)), 0);
}

void rejects_bad_arguments(void **) {
    const cv::Mat1i model_of(8, 8, 0);
    const std::vector<cv::Point> pts = {cv::Point(1, 1)};
    const std::vector<float> one = {1.0f}, none;
    const auto call = [&](const std::vector<cv::Point> &p, const std::vector<float> &r, float radius, float prior) {
        return [=, &model_of] { (void)lidar_residual_correction(model_of, p, r, radius, prior); };
    };
    test::expect_error(call(pts, none, 2, 0.05f), ErrorCode::InvalidArgument);
    test::expect_error(call(pts, one, -1, 0.05f), ErrorCode::InvalidArgument);
    test::expect_error(call(pts, one, 65, 0.05f), ErrorCode::InvalidArgument);
    test::expect_error(call(pts, one, std::nanf(""), 0.05f), ErrorCode::InvalidArgument);
    test::expect_error(call(pts, one, 2, 0.0f), ErrorCode::InvalidArgument);
    for (int threads : {0, -1, 1025})
        test::expect_error([&] { (void)lidar_residual_correction(model_of, pts, one, 2, 0.05f, threads); },
                           ErrorCode::InvalidArgument);
    test::expect_error(call({cv::Point(8, 1)}, one, 2, 0.05f), ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(equals_its_definition),
        cmocka_unit_test(weights_and_models),
        cmocka_unit_test(rejects_bad_arguments),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
