// SPDX-License-Identifier: MIT
// The geodesic distance transform of build_seed_graph against the plain one-pixel-at-a-time
// sweeps (each pixel tries W, N, NW, NE forward and E, S, SE, SW backward, keeping the first
// least candidate): the same distances and nearest seeds, bit for bit, ties included. And the
// seed search's one-traversal pair of neighbour lists against two separate searches.
#include "test_support.hpp"

#include <cstring>
#include <random>
#include <vector>

#include "interpolation/geodesic.hpp"

using namespace lidarflow::interpolation;

namespace {

void reference_sweeps(const cv::Mat1f &edges, const std::vector<cv::Point> &seeds, float gain, cv::Mat1f &dist,
                      cv::Mat1i &lab) {
    const int w = edges.cols, h = edges.rows;
    dist.create(h, w);
    dist.setTo(std::numeric_limits<float>::infinity());
    lab.create(h, w);
    lab.setTo(-1);
    for (size_t i = 0; i < seeds.size(); ++i) {
        dist(seeds[i]) = 0.0f;
        lab(seeds[i]) = static_cast<int>(i);
    }
    cv::Mat1f half(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) half(y, x) = 0.5f * (1.0f + gain * edges(y, x));
    float *d = dist.ptr<float>();
    int *l = lab.ptr<int>();
    const float *hc = half.ptr<float>();
    constexpr float kDiag = 1.41421356f;
    auto relax = [&](int idx, int q, float len) {
        const float nd = d[q] + len * (hc[idx] + hc[q]);
        if (nd < d[idx]) {
            d[idx] = nd;
            l[idx] = l[q];
        }
    };
    for (int pass = 0; pass < 2; ++pass) {
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const int idx = y * w + x;
                if (x > 0) relax(idx, idx - 1, 1.0f);
                if (y > 0) {
                    relax(idx, idx - w, 1.0f);
                    if (x > 0) relax(idx, idx - w - 1, kDiag);
                    if (x + 1 < w) relax(idx, idx - w + 1, kDiag);
                }
            }
        for (int y = h - 1; y >= 0; --y)
            for (int x = w - 1; x >= 0; --x) {
                const int idx = y * w + x;
                if (x + 1 < w) relax(idx, idx + 1, 1.0f);
                if (y + 1 < h) {
                    relax(idx, idx + w, 1.0f);
                    if (x + 1 < w) relax(idx, idx + w + 1, kDiag);
                    if (x > 0) relax(idx, idx + w - 1, kDiag);
                }
            }
    }
}

void distance_transform_equals_the_plain_sweeps(void **) {
    std::mt19937 gen(3);
    int compared = 0;
    for (cv::Size size : {cv::Size(1, 1), cv::Size(1, 9), cv::Size(9, 1), cv::Size(2, 3), cv::Size(37, 23),
                          cv::Size(160, 96)})
        for (int flat = 0; flat < 2; ++flat) {
            // Flat maps (no edges) are full of equal distances: the ties must go the same way.
            cv::Mat1f edges(size, 0.0f);
            if (!flat) cv::randu(edges, 0.0f, 1.0f);
            std::vector<cv::Point> seeds;
            cv::Mat1b used(size, 0);
            const int n = std::max(1, size.area() / 40);
            std::uniform_int_distribution<int> px(0, size.width - 1), py(0, size.height - 1);
            while (static_cast<int>(seeds.size()) < n) {
                const cv::Point p(px(gen), py(gen));
                if (used(p)) continue;
                used(p) = 1;
                seeds.push_back(p);
            }
            const SeedGraph g = build_seed_graph(edges, seeds, 3.0f);
            cv::Mat1f dist;
            cv::Mat1i lab;
            reference_sweeps(edges, seeds, 3.0f, dist, lab);
            assert_int_equal(std::memcmp(dist.ptr(), g.distance.ptr(), size.area() * sizeof(float)), 0);
            assert_int_equal(std::memcmp(lab.ptr(), g.nearest.ptr(), size.area() * sizeof(int)), 0);
            ++compared;
        }
    assert_int_equal(compared, 12);
}

// The interpolator asks for the k nearest seeds and the k nearest seeds with a motion from the
// same pixel in one traversal: each list must be what its own search returns, ties included.
void one_traversal_gives_both_neighbour_lists(void **) {
    std::mt19937 gen(5);
    int compared = 0, differ = 0;
    for (int flat = 0; flat < 2; ++flat) {
        const cv::Size size(64, 40);
        cv::Mat1f edges(size, 0.0f);
        if (!flat) cv::randu(edges, 0.0f, 1.0f);
        std::vector<cv::Point> seeds;
        cv::Mat1b used(size, 0);
        std::uniform_int_distribution<int> px(0, size.width - 1), py(0, size.height - 1);
        while (seeds.size() < 90) {
            const cv::Point p(px(gen), py(gen));
            if (used(p)) continue;
            used(p) = 1;
            seeds.push_back(p);
        }
        std::vector<char> moving(seeds.size());
        for (char &m : moving) m = gen() % 3 != 0;
        const auto accept = [&](int i) { return moving[i] != 0; };
        const SeedGraph g = build_seed_graph(edges, seeds, 3.0f);
        SeedSearch search(g.num_seeds());
        std::vector<std::pair<int, float>> all, some, all2, some2;
        for (int q = 0; q < 40; ++q) {
            const cv::Point from(px(gen), py(gen));
            for (auto [k, kb] : {std::pair{16, 16}, {5, 30}, {30, 5}, {0, 8}, {8, 0}, {200, 200}}) {
                search.nearest(g, from, k, [](int) { return true; }, all);
                search.nearest(g, from, kb, accept, some);
                search.nearest_two(g, from, k, all2, kb, accept, some2);
                assert_true(all == all2);
                assert_true(some == some2);
                differ += all != some;
                ++compared;
            }
        }
    }
    assert_int_equal(compared, 2 * 40 * 6);
    assert_true(differ > 0);  // the lists are not trivially the same
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(distance_transform_equals_the_plain_sweeps),
        cmocka_unit_test(one_traversal_gives_both_neighbour_lists),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
