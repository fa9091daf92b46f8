// SPDX-License-Identifier: MIT
// The project's SGM with a LiDAR term (stereo/guided_sgm.hpp) and the thinning of dense scans
// for stages 2-4 (lidar/binning.hpp): a textured pair at a known disparity, a textureless
// square that only the LiDAR can place, a dithered flat square that only ternary census lets the
// LiDAR place, determinism over threads, the data costs' vector loop against the scalar one and
// the definition, refused inputs.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "lidar/binning.hpp"
#include "stereo/guided_sgm.hpp"
#include "synth_fields.hpp"
#include "test_support.hpp"

using namespace lidarflow;

namespace {

constexpr int kW = 200, kH = 100;

// A random texture (blurred noise, so that census windows see gradients, not single pixels).
cv::Mat1b texture(int w, int h, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> v(0, 255);
    cv::Mat1b m(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) m(y, x) = static_cast<uint8_t>(v(rng));
    cv::GaussianBlur(m, m, cv::Size(3, 3), 0.8);
    return m;
}

// Left and right views of a textured plane at disparity `bg`, with, when square > 0, a flat
// (textureless) square of that side at disparity `fg` in the middle.
void scene(int bg, int fg, int square, cv::Mat1b &left, cv::Mat1b &right) {
    const cv::Mat1b t = texture(kW + 64, kH, 7);
    left.create(kH, kW);
    right.create(kH, kW);
    const int x0 = kW / 2 - square / 2, y0 = kH / 2 - square / 2;
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            left(y, x) = t(y, x + 32);
            right(y, x) = t(y, x + 32 + bg);  // the right image sees the plane bg px further right
        }
    if (square <= 0) return;
    for (int y = y0; y < y0 + square; ++y)
        for (int x = x0; x < x0 + square; ++x) {
            left(y, x) = 128;
            right(y, x - fg) = 128;
        }
}

double share_near(const DisparityMap &d, cv::Rect r, float value, float tol) {
    int n = 0, good = 0;
    for (int y = r.y; y < r.y + r.height; ++y)
        for (int x = r.x; x < r.x + r.width; ++x) {
            ++n;
            if (disparity_valid(d(y, x)) && std::fabs(d(y, x) - value) <= tol) ++good;
        }
    return static_cast<double>(good) / n;
}

stereo::GuidedSgmOptions options(int threads = 2) {
    stereo::GuidedSgmOptions o;
    o.num_disparities = 48;
    o.threads = threads;
    return o;
}

// A textured plane is matched at its disparity almost everywhere right of the search range.
void textured_plane(void **) {
    cv::Mat1b l, r;
    scene(12, 0, 0, l, r);
    const SparseLidar none{kW, kH, {}};
    const DisparityMap d = stereo::guided_sgm(l, r, none, options());
    const double share = share_near(d, cv::Rect(48, 5, kW - 53, kH - 10), 12.0f, 0.5f);
    std::printf("textured plane: %.3f of the pixels at 12 +- 0.5 px\n", share);
    assert_true(share > 0.97);
}

// In a textureless square every disparity costs the same: image-only SGM cannot place it, the
// LiDAR points inside can, and the smoothness term carries them across the square.
void lidar_places_a_textureless_square(void **) {
    cv::Mat1b l, r;
    scene(8, 24, 40, l, r);
    const cv::Rect inner(kW / 2 - 16, kH / 2 - 16, 32, 32);
    SparseLidar lidar{kW, kH, {}};
    for (int y = kH / 2 - 15; y <= kH / 2 + 15; y += 10)  // 16 points, 10 px apart
        for (int x = kW / 2 - 15; x <= kW / 2 + 15; x += 10) lidar.points.push_back({x, y, 24.0f});
    const DisparityMap image_only = stereo::guided_sgm(l, r, SparseLidar{kW, kH, {}}, options());
    const DisparityMap guided = stereo::guided_sgm(l, r, lidar, options());
    const double before = share_near(image_only, inner, 24.0f, 1.0f), after = share_near(guided, inner, 24.0f, 1.0f);
    std::printf("textureless square at 24 +- 1 px: %.3f image-only, %.3f with 16 LiDAR points\n", before, after);
    assert_true(before < 0.5);
    assert_true(after > 0.9);
    // The background keeps its disparity: the points guide their own surface only.
    assert_true(share_near(guided, cv::Rect(52, 5, 40, 20), 8.0f, 0.5f) > 0.95);
}

// A flat square under a one-level dither (each image its own): binary census bits follow the
// dither, so every disparity's cost is noise and the LiDAR points' priors do not carry across
// the square; ternary census with a threshold of 1 sees no neighbour there, costs 0 at every
// disparity, and the paths spread the points' disparity.
void ternary_census_ignores_a_dithered_flat_square(void **) {
    cv::Mat1b l, r;
    scene(8, 24, 40, l, r);
    std::mt19937 rng(3);
    std::uniform_int_distribution<int> bit(0, 1);
    const cv::Rect sq(kW / 2 - 20, kH / 2 - 20, 40, 40);
    for (cv::Mat1b *m : {&l, &r})
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x)
                if ((*m)(y, x) == 128) (*m)(y, x) = static_cast<uint8_t>(128 + bit(rng));
    SparseLidar lidar{kW, kH, {}};
    for (int y = kH / 2 - 15; y <= kH / 2 + 15; y += 15)  // 9 points, 15 px apart
        for (int x = kW / 2 - 15; x <= kW / 2 + 15; x += 15) lidar.points.push_back({x, y, 24.0f});
    const cv::Rect inner(sq.x + 4, sq.y + 4, sq.width - 8, sq.height - 8);
    stereo::GuidedSgmOptions binary = options(), ternary = options();
    ternary.ternary_census = true;
    ternary.census_threshold = 1;
    const DisparityMap with_ternary = stereo::guided_sgm(l, r, lidar, ternary);
    const double b = share_near(stereo::guided_sgm(l, r, lidar, binary), inner, 24.0f, 1.0f);
    const double t = share_near(with_ternary, inner, 24.0f, 1.0f);
    std::printf("dithered square at 24 +- 1 px with 9 points: %.3f binary census, %.3f ternary\n", b, t);
    assert_true(t > 0.9);
    assert_true(t > b + 0.2);
    // The textured background keeps its disparity with either census.
    assert_true(share_near(with_ternary, cv::Rect(52, 5, 40, 20), 8.0f, 0.5f) > 0.95);
}

// Integer arithmetic throughout: one, two or three threads give the same map bit for bit.
void threads_do_not_change_the_result(void **) {
    cv::Mat1b l, r;
    scene(8, 24, 40, l, r);
    SparseLidar lidar{kW, kH, {{100, 50, 24.0f}, {30, 20, 8.0f}}};
    const DisparityMap one = stereo::guided_sgm(l, r, lidar, options(1));
    for (int t : {2, 3}) assert_true(test::same_mat(one, stereo::guided_sgm(l, r, lidar, options(t))));
    stereo::GuidedSgmOptions four = options(2);
    four.paths = 4;
    const DisparityMap d4 = stereo::guided_sgm(l, r, lidar, four);
    four.threads = 3;
    assert_true(test::same_mat(d4, stereo::guided_sgm(l, r, lidar, four)));
    stereo::GuidedSgmOptions ternary = options(1);
    ternary.ternary_census = true;
    ternary.census_threshold = 2;
    const DisparityMap t1 = stereo::guided_sgm(l, r, lidar, ternary);
    ternary.threads = 3;
    assert_true(test::same_mat(t1, stereo::guided_sgm(l, r, lidar, ternary)));
}

// A densified prior: the point's own pixel at full weight, neighbours of another intensity none.
void prior_stays_on_its_surface(void **) {
    cv::Mat1b g(20, 20, static_cast<uint8_t>(50));
    g(cv::Rect(10, 0, 10, 20)) = 200;
    stereo::GuidedSgmOptions o = options();
    o.lidar_radius = 3;
    const stereo::LidarPrior p = stereo::densify_lidar(g, SparseLidar{20, 20, {{9, 10, 5.0f}}}, o);
    assert_int_equal(p.weight(10, 9), 255);
    assert_float_equal(p.disparity(10, 9), 5.0f, 0);
    assert_true(p.weight(10, 7) > 0 && p.weight(10, 7) < 255);
    assert_int_equal(p.weight(10, 10), 0);  // across the intensity edge
    assert_int_equal(p.weight(10, 5), 0);   // beyond the radius
}

// The densified prior against its definition, pixel by pixel: of the points within the radius
// (Chebyshev) whose intensity the pixel shares, or whose own pixel it is, the nearest, then the
// largest disparity; the weight by that distance. Dense points (ties of distance everywhere),
// points on the border, any thread count.
void prior_equals_its_definition(void **) {
    std::mt19937 gen(31);
    const int w = 61, h = 37;
    std::uniform_int_distribution<int> grey(100, 140), px(0, w - 1), py(0, h - 1), step(0, 3);
    cv::Mat1b g(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) g(y, x) = static_cast<uint8_t>(grey(gen));
    for (int count : {1, 40, 600}) {
        SparseLidar lidar{w, h, {}};
        cv::Mat1b used(h, w, uchar(0));
        lidar.points.push_back({0, h - 1, 3.0f});
        used(h - 1, 0) = 1;
        while (static_cast<int>(lidar.points.size()) < count) {
            const int x = px(gen), y = py(gen);
            if (used(y, x)) continue;
            used(y, x) = 1;
            // Few distinct disparities: equally near points often differ, sometimes not.
            lidar.points.push_back({x, y, static_cast<float>(2 + step(gen))});
        }
        // Windows of one and of several 8-pixel lane groups.
        for (int r : {0, 1, 3, 4, 9}) {
            stereo::GuidedSgmOptions o = options(1);
            o.lidar_radius = r;
            o.lidar_intensity = 12;
            cv::Mat1f want_d(h, w, kInvalidDisparity);
            cv::Mat1b want_w(h, w, uchar(0));
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    int best = r + 1;
                    float d = kInvalidDisparity;
                    for (const LidarPoint &pt : lidar.points) {
                        const int dd = std::max(std::abs(x - pt.x), std::abs(y - pt.y));
                        if (dd > r || (dd > 0 && std::abs(g(y, x) - g(pt.y, pt.x)) > o.lidar_intensity)) continue;
                        if (dd < best || (dd == best && pt.disparity > d)) best = dd, d = pt.disparity;
                    }
                    if (best > r) continue;
                    want_d(y, x) = d;
                    want_w(y, x) = static_cast<uint8_t>(255 * (r + 1 - best) / (r + 1));
                }
            for (int threads : {1, 3}) {
                o.threads = threads;
                const stereo::LidarPrior p = stereo::densify_lidar(g, lidar, o);
                assert_true(test::same_mat(p.disparity, want_d));
                assert_true(test::same_mat(p.weight, want_w));
            }
        }
    }
}

// A featureless pair ties at every disparity: no pixel gets one (not disparity 0), while one
// LiDAR point still places the pixels its prior reaches.
// The data costs' vector loop gives the scalar loop's bytes, and both are the definition: the
// popcount of the signatures' XOR (ternary: both planes, halved, rounded up), the right image's
// column 0 left of the image, plus on weighted pixels the LiDAR penalty round(weight *
// min(slope * |d - prior|, cap) / 255), saturated at 255; priors inside and beyond the range, a
// penalty rising over few or many disparities (the vector loop's capped span and its fallback).
void data_costs_vector_equals_scalar(void **) {
    std::mt19937_64 rng(7);
    const int w = 203;
    struct Penalty {
        int slope16, cap;
    };
    for (const int D : {16, 32, 64, 80, 96})
        for (const bool ternary : {false, true})
            for (const Penalty pen : {Penalty{64, 40}, Penalty{16, 192}, Penalty{1024, 192}, Penalty{0, 40},
                                      Penalty{48, 0}, Penalty{20, 18}}) {
                std::vector<uint64_t> dl(w), dr(w), bl(w), br(w);
                std::vector<int16_t> prior(w);
                std::vector<uint8_t> weight(w);
                for (int x = 0; x < w; ++x) {
                    // 62 census bits; every fourth pixel a sparse or a dense signature.
                    const uint64_t mask = x % 4 == 1 ? 0x0101010101010101ull : (1ull << 62) - 1;
                    dl[x] = rng() & mask, dr[x] = rng() & mask;
                    bl[x] = rng() & mask & ~dl[x], br[x] = rng() & mask & ~dr[x];
                    prior[x] = static_cast<int16_t>(x % 11 == 0 ? 16 * D + rng() % 4000 : rng() % (16 * D));
                    weight[x] = x % 3 == 0 ? static_cast<uint8_t>(rng() % 256) : x % 5 == 0 ? 255 : 0;
                }
                std::vector<uint8_t> vec(static_cast<size_t>(w) * D), sca(vec.size());
                const uint64_t *b0 = ternary ? bl.data() : nullptr, *b1 = ternary ? br.data() : nullptr;
                stereo::detail::row_costs(ternary, dl.data(), dr.data(), b0, b1, prior.data(), weight.data(), w, D,
                                          pen.slope16, pen.cap, true, vec.data());
                stereo::detail::row_costs(ternary, dl.data(), dr.data(), b0, b1, prior.data(), weight.data(), w, D,
                                          pen.slope16, pen.cap, false, sca.data());
                assert_true(vec == sca);
                for (int x = 0; x < w; ++x)
                    for (int d = 0; d < D; ++d) {
                        const int xr = std::max(0, x - d);
                        int n = __builtin_popcountll(dl[x] ^ dr[xr]);
                        if (ternary) n = (n + __builtin_popcountll(bl[x] ^ br[xr]) + 1) / 2;
                        const int penalty = std::min(pen.slope16 * std::abs(16 * d - prior[x]) / 256, pen.cap);
                        n += (weight[x] * penalty + 127) / 255;
                        assert_int_equal(vec[static_cast<size_t>(x) * D + d], std::min(n, 255));
                    }
            }
}

// The horizontal paths' register kernel gives the scalar loop's sums for every vector count
// (D = 16 .. 128) and past it (D = 144 takes the scalar loop either way), with fixed and adaptive
// P2, on costs up to the LiDAR penalty's 255 and an image with flat runs and steps.
void horizontal_paths_vector_equals_scalar(void **) {
    std::mt19937_64 rng(11);
    const int w = 157;
    std::vector<uint8_t> img(w);
    for (int x = 0; x < w; ++x) img[x] = x % 9 < 4 ? 100 : static_cast<uint8_t>(rng() % 256);
    for (const int D : {16, 32, 48, 64, 80, 96, 112, 128, 144})
        for (const bool adaptive : {false, true}) {
            std::vector<uint8_t> cost(static_cast<size_t>(w) * D);
            for (uint8_t &c : cost)
                c = rng() % 5 == 0 ? static_cast<uint8_t>(rng() % 256) : static_cast<uint8_t>(rng() % 40);
            std::vector<uint16_t> vec(cost.size(), 1), sca(cost.size(), 2);
            stereo::detail::horizontal_paths(cost.data(), img.data(), w, D, 10, 120, adaptive, true, vec.data());
            stereo::detail::horizontal_paths(cost.data(), img.data(), w, D, 10, 120, adaptive, false, sca.data());
            assert_true(vec == sca);
            // The first pixel of each direction takes its data cost alone: pixel 0's sum is its
            // cost plus the right-to-left path's value there.
            for (int d = 0; d < D; ++d) assert_true(vec[static_cast<size_t>(d)] >= cost[static_cast<size_t>(d)]);
        }
}

// The winners' vector kernel gives the scalar loop's winners, and both the definition: the least
// sum's smallest d, unless a sum more than 1 px away is within the uniqueness margin or the right
// image's winner (least sum, then smallest d, over the left pixels that reach it) is more than
// lr_max_diff away. Sums with planted ties and the largest value; images narrower than D too.
void winners_vector_equals_scalar(void **) {
    std::mt19937_64 rng(5);
    for (const int w : {157, 40})
        for (const int D : {16, 48, 80, 128, 144}) {
            std::vector<uint16_t> S(static_cast<size_t>(w) * D);
            for (uint16_t &v : S) {
                const uint64_t r = rng() % 16;
                v = r == 0   ? UINT16_MAX
                    : r < 4  ? static_cast<uint16_t>(300 + rng() % 4)
                             : static_cast<uint16_t>(rng() % 3000);
            }
            for (const int uniqueness : {0, 10, 60})
                for (const int lr : {-1, 0, 2}) {
                    std::vector<uint16_t> scratch(2 * (static_cast<size_t>(w) + D));
                    std::vector<int16_t> vec(w), sca(w);
                    stereo::detail::row_winners(S.data(), w, D, uniqueness, lr, true, scratch.data(), vec.data());
                    stereo::detail::row_winners(S.data(), w, D, uniqueness, lr, false, scratch.data(), sca.data());
                    assert_true(vec == sca);
                    const auto sum = [&](int x, int d) { return S[static_cast<size_t>(x) * D + d]; };
                    for (int x = 0; x < w; ++x) {
                        const int lim = std::min(D, x + 1);
                        int b = 0;
                        for (int d = 1; d < lim; ++d) b = sum(x, d) < sum(x, b) ? d : b;
                        int other = -1;
                        for (int d = 0; d < lim; ++d)
                            if (std::abs(d - b) > 1 && (other < 0 || sum(x, d) < other)) other = sum(x, d);
                        const bool unique =
                            other >= 0 && int64_t{other} * (100 - uniqueness) > int64_t{100} * sum(x, b);
                        int want = unique ? b : -1;
                        if (want >= 0 && lr >= 0) {
                            const int p = x - want;  // the right pixel: its least (sum, d) over x' = p + d
                            int rb = 0;
                            for (int d = 1; d < D && p + d < w; ++d) rb = sum(p + d, d) < sum(p + rb, rb) ? d : rb;
                            if (std::abs(rb - want) > lr) want = -1;
                        }
                        assert_int_equal(vec[static_cast<size_t>(x)], want);
                    }
                }
        }
}

void featureless_pair_has_no_disparity(void **) {
    const cv::Mat1b flat(kH, kW, uchar(90));
    const DisparityMap d = stereo::guided_sgm(flat, flat, SparseLidar{kW, kH, {}}, options());
    assert_int_equal(cv::countNonZero(d >= 0.0f), 0);
    const DisparityMap g = stereo::guided_sgm(flat, flat, SparseLidar{kW, kH, {{kW / 2, kH / 2, 12.0f}}}, options());
    assert_true(g(kH / 2, kW / 2) >= 11.0f && g(kH / 2, kW / 2) <= 13.0f);
}

void bad_inputs_are_refused(void **) {
    cv::Mat1b l, r;
    scene(8, 0, 0, l, r);
    const SparseLidar none{kW, kH, {}};
    assert_true(test::throws_code(ErrorCode::SizeMismatch, [&] {
        stereo::guided_sgm(l, r(cv::Rect(0, 0, kW - 1, kH)), none, options());
    }));
    assert_true(test::throws_code(ErrorCode::InvalidArgument,
                                  [&] { stereo::guided_sgm(cv::Mat(), cv::Mat(), none, options()); }));
    assert_true(test::throws_code(ErrorCode::SizeMismatch,
                                  [&] { stereo::guided_sgm(l, r, SparseLidar{kW + 1, kH, {{1, 1, 2.0f}}}, options()); }));
    stereo::GuidedSgmOptions bad = options();
    bad.num_disparities = 40;
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { stereo::guided_sgm(l, r, none, bad); }));
    bad = options();
    bad.paths = 6;
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { stereo::guided_sgm(l, r, none, bad); }));
    bad = options();
    bad.census_threshold = 65;
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { stereo::guided_sgm(l, r, none, bad); }));
    bad.census_threshold = -1;
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { stereo::guided_sgm(l, r, none, bad); }));
    bad = options();
    bad.lidar_slope = NAN;
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { stereo::guided_sgm(l, r, none, bad); }));
}

// Binning keeps at most one point per cell, whatever the scan's density, and leaves a sparse
// input (no two points in one cell) unchanged.
void binning_bounds_the_points(void **) {
    SparseLidar dense{64, 32, {}};
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x) dense.points.push_back({x, y, static_cast<float>(x % 7)});
    for (int cell : {2, 4, 8}) {
        const SparseLidar b = lidar::bin_points(dense, cell);
        assert_int_equal(b.points.size(), static_cast<size_t>((64 / cell) * (32 / cell)));
    }
    const SparseLidar b4 = lidar::bin_points(dense, 4);  // the pixel nearest the centre, nearer surface on ties
    for (const LidarPoint &p : b4.points) {
        assert_true(p.x % 4 == 1 || p.x % 4 == 2);
        assert_true(p.y % 4 == 1 || p.y % 4 == 2);
    }
    const SparseLidar sparse{64, 32, {{1, 1, 3.0f}, {20, 9, 4.0f}, {40, 30, 5.0f}}};
    const SparseLidar same = lidar::bin_points(sparse, 8);
    assert_int_equal(same.points.size(), 3);
    assert_int_equal(lidar::bin_points(dense, 0).points.size(), dense.points.size());
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(textured_plane),
        cmocka_unit_test(lidar_places_a_textureless_square),
        cmocka_unit_test(ternary_census_ignores_a_dithered_flat_square),
        cmocka_unit_test(threads_do_not_change_the_result),
        cmocka_unit_test(prior_stays_on_its_surface),
        cmocka_unit_test(prior_equals_its_definition),
        cmocka_unit_test(bad_inputs_are_refused),
        cmocka_unit_test(featureless_pair_has_no_disparity),
        cmocka_unit_test(data_costs_vector_equals_scalar),
        cmocka_unit_test(horizontal_paths_vector_equals_scalar),
        cmocka_unit_test(winners_vector_equals_scalar),
        cmocka_unit_test(binning_bounds_the_points),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
