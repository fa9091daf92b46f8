// SPDX-License-Identifier: MIT
// The geodesic distance transform of build_seed_graph against the plain one-pixel-at-a-time
// sweeps (each pixel tries W, N, NW, NE forward and E, S, SE, SW backward, keeping the first
// least candidate): the same distances and nearest seeds, bit for bit, ties included. And the
// seed search's one-traversal pair of neighbour lists against two separate searches; the seed
// links against every border pixel pair; the search order against a plain Dijkstra; edge values
// out of range refused.
#include "test_support.hpp"

#include <cstring>
#include <map>
#include <queue>
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

// n distinct random pixels.
std::vector<cv::Point> random_seeds(std::mt19937 &gen, cv::Size size, size_t n) {
    std::vector<cv::Point> seeds;
    cv::Mat1b used(size, 0);
    std::uniform_int_distribution<int> px(0, size.width - 1), py(0, size.height - 1);
    while (seeds.size() < n) {
        const cv::Point p(px(gen), py(gen));
        if (used(p)) continue;
        used(p) = 1;
        seeds.push_back(p);
    }
    return seeds;
}

// Every pair of 4-neighbouring pixels in different cells links the two seeds with the path
// through it; a link keeps the least, lists sorted by neighbour (the same on any thread count).
void seed_links_are_the_least_border_paths(void **) {
    std::mt19937 gen(11);
    for (int flat = 0; flat < 2; ++flat)
        for (size_t n : {size_t{1}, size_t{2}, size_t{40}, size_t{900}}) {
            const cv::Size size(61, 37);
            cv::Mat1f edges(size, 0.0f);
            if (!flat) cv::randu(edges, 0.0f, 1.0f);
            const std::vector<cv::Point> seeds = random_seeds(gen, size, n);
            for (const int threads : {1, 3, 8}) {  // bands of rows linked apart, then merged
                const SeedGraph g = build_seed_graph(edges, seeds, 2.0f, threads);
                std::vector<std::map<int, float>> want(n);
                const auto half = [&](int y, int x) { return 0.5f * (1.0f + 2.0f * edges(y, x)); };
                for (int y = 0; y < size.height; ++y)
                    for (int x = 0; x < size.width; ++x)
                        for (cv::Point q : {cv::Point(x + 1, y), cv::Point(x, y + 1)}) {
                            if (q.x >= size.width || q.y >= size.height) continue;
                            const int a = g.nearest(y, x), b = g.nearest(q);
                            if (a == b) continue;
                            const float wgt = g.distance(y, x) + half(y, x) + half(q.y, q.x) + g.distance(q);
                            for (auto [i, j] : {std::pair{a, b}, std::pair{b, a}}) {
                                auto it = want[i].find(j);
                                if (it == want[i].end()) want[i][j] = wgt;
                                else it->second = std::min(it->second, wgt);
                            }
                        }
                assert_int_equal(g.num_seeds(), static_cast<int>(n));
                for (size_t i = 0; i < n; ++i) {
                    assert_int_equal(g.start[i + 1] - g.start[i], static_cast<int>(want[i].size()));
                    int e = g.start[i];
                    for (const auto &[j, wgt] : want[i]) {
                        assert_int_equal(g.nbr[e], j);
                        assert_true(g.weight[e] == wgt);
                        ++e;
                    }
                }
                if (n > 1) assert_true(g.start[n] > 0);
            }
        }
}

// An edge value below 0 or not finite gives a step a cost below 1, infinite or not a number: refused.
void edge_values_out_of_range_are_refused(void **) {
    const std::vector<cv::Point> seeds = {{1, 1}, {5, 3}};
    for (const float bad : {-0.25f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
        cv::Mat1f edges(6, 9, 0.5f);
        edges(4, 7) = bad;
        lidarflow::test::expect_error([&] { build_seed_graph(edges, seeds, 1.0f); },
                                      lidarflow::ErrorCode::InvalidArgument);
    }
    const cv::Mat1f fine(6, 9, 0.5f);
    assert_int_equal(build_seed_graph(fine, seeds, 1.0f).num_seeds(), 2);
}

// The search settles seeds by (distance, seed index), as a plain Dijkstra over (distance,
// seed) pairs does; on a flat map many distances tie.
void search_settles_in_dijkstra_order(void **) {
    std::mt19937 gen(13);
    int compared = 0;
    for (int flat = 0; flat < 2; ++flat) {
        const cv::Size size(80, 50);
        cv::Mat1f edges(size, 0.0f);
        if (!flat) cv::randu(edges, 0.0f, 1.0f);
        const std::vector<cv::Point> seeds = random_seeds(gen, size, 300);
        const SeedGraph g = build_seed_graph(edges, seeds, 3.0f);
        SeedSearch search(g.num_seeds());
        std::uniform_int_distribution<int> px(0, size.width - 1), py(0, size.height - 1);
        std::vector<std::pair<int, float>> got;
        for (int q = 0; q < 30; ++q) {
            const cv::Point from(px(gen), py(gen));
            std::vector<std::pair<int, float>> want;
            std::vector<float> best(seeds.size(), std::numeric_limits<float>::infinity());
            std::vector<char> done(seeds.size(), 0);
            std::priority_queue<std::pair<float, int>, std::vector<std::pair<float, int>>,
                                std::greater<std::pair<float, int>>>
                heap;
            const int s0 = g.nearest(from);
            best[s0] = g.distance(from);
            heap.emplace(best[s0], s0);
            while (!heap.empty()) {
                const auto [d, s] = heap.top();
                heap.pop();
                if (done[s] || d > best[s]) continue;
                done[s] = 1;
                want.emplace_back(s, d);
                for (int e = g.start[s]; e < g.start[s + 1]; ++e) {
                    const int t = g.nbr[e];
                    const float nd = d + g.weight[e];
                    if (!done[t] && nd < best[t]) {
                        best[t] = nd;
                        heap.emplace(nd, t);
                    }
                }
            }
            for (int k : {1, 17, 300, 1000}) {
                search.nearest(g, from, k, [](int) { return true; }, got);
                const size_t n = std::min<size_t>(k, want.size());
                assert_int_equal(got.size(), n);
                assert_true(std::equal(got.begin(), got.end(), want.begin()));
                ++compared;
            }
        }
    }
    assert_int_equal(compared, 2 * 30 * 4);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(distance_transform_equals_the_plain_sweeps),
        cmocka_unit_test(one_traversal_gives_both_neighbour_lists),
        cmocka_unit_test(seed_links_are_the_least_border_paths),
        cmocka_unit_test(search_settles_in_dijkstra_order),
        cmocka_unit_test(edge_values_out_of_range_are_refused),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
