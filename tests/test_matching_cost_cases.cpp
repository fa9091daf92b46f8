// SPDX-License-Identifier: MIT
// The matching cost: patch distance (Eq. 2) and the four LiDAR cases (Eqs. 3, 7, 10, 12),
// checked against terms computed independently here from the paper's pixel positions, and
// the matcher's reported seed costs checked against the same case formulas.
#include "test_support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "core/error.hpp"
#include "features/dense_sift.hpp"
#include "matching/cost_cases.hpp"
#include "matching/patch_cost.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "synth/scene.hpp"

using namespace lidarflow;
using namespace lidarflow::matching;
using features::DescriptorImage;

namespace {

DescriptorImage random_descriptors(int w, int h, int dim, uint32_t seed) {
    std::mt19937 rng(seed);
    DescriptorImage d;
    d.width = w;
    d.height = h;
    d.dim = dim;
    d.data.resize(size_t(w) * h * dim);
    for (auto &v : d.data) v = static_cast<uint8_t>(rng() & 0xFF);
    return d;
}

// Eq. 2 written out: full 7x7 patch, Euclidean distance, no sampling tricks.
double reference_E(const DescriptorImage &a, const DescriptorImage &b, int ax, int ay, int bx, int by) {
    double sum = 0;
    for (int dy = -3; dy <= 3; ++dy)
        for (int dx = -3; dx <= 3; ++dx) {
            const uint8_t *p = a.at(ax + dx, ay + dy), *q = b.at(bx + dx, by + dy);
            double s = 0;
            for (int i = 0; i < a.dim; ++i) s += double(int(p[i]) - int(q[i])) * (int(p[i]) - int(q[i]));
            sum += std::sqrt(s);
        }
    return sum;
}

struct Four {
    DescriptorImage l0, r0, l1, r1;
    SlotDescriptors slots() const {
        SlotDescriptors s;
        s.image[kL0] = &l0;
        s.image[kR0] = &r0;
        s.image[kL1] = &l1;
        s.image[kR1] = &r1;
        return s;
    }
};

void near(double a, double b) {
    if (std::abs(a - b) > 1e-4 * std::max(1.0, std::abs(b))) fail_msg("%.6f != %.6f", a, b);
}

void patch_distance_matches_eq2(void **) {
    const DescriptorImage a = random_descriptors(20, 16, 32, 1), b = random_descriptors(20, 16, 32, 2);
    const PatchShape full(3, 1);
    assert_int_equal(full.samples(), 49);
    near(patch_cost(a, b, 8, 7, 11, 9, full, DescriptorNorm::L2, 1e9f), reference_E(a, b, 8, 7, 11, 9));
    // L1 on one descriptor pair.
    double l1 = 0;
    for (int i = 0; i < 32; ++i) l1 += std::abs(int(a.at(5, 5)[i]) - int(b.at(6, 4)[i]));
    near(descriptor_distance(a.at(5, 5), b.at(6, 4), 32, DescriptorNorm::L1), l1);
    // Sub-sampled 7x7 patch (step 3): the 3x3 samples at offsets -3, 0, 3.
    const PatchShape sub(3, 3);
    assert_int_equal(sub.samples(), 9);
    double s = 0;
    for (int dy = -3; dy <= 3; dy += 3)
        for (int dx = -3; dx <= 3; dx += 3)
            s += descriptor_distance(a.at(8 + dx, 7 + dy), b.at(11 + dx, 9 + dy), 32, DescriptorNorm::L2);
    near(patch_cost(a, b, 8, 7, 11, 9, sub, DescriptorNorm::L2, 1e9f), s);
    near(patch_cost_baseline_kernel(a.bits)(a, b, 8, 7, 11, 9, sub, DescriptorNorm::L2, 1e9f,
                                      std::numeric_limits<float>::infinity()),
         s);
}

// Packed 4-bit descriptors (DenseSiftOptions::bits = 4): random codes and contrasts.
DescriptorImage random_packed(int w, int h, int dim, uint32_t seed) {
    DescriptorImage d = random_descriptors(w, h, dim / 2, seed);
    d.dim = dim;
    d.bits = 4;
    std::mt19937 rng(seed + 100);
    d.contrast.resize(size_t(w) * h);
    for (auto &c : d.contrast) c = static_cast<uint8_t>(rng() % (features::kContrastSteps + 1));
    return d;
}

int decoded(const DescriptorImage &d, int x, int y, int i) {
    const uint8_t byte = d.at(x, y)[i % (d.dim / 2)];
    const uint8_t *levels = features::packed_levels(d.contrast[size_t(y) * d.width + x]);
    return levels[i < d.dim / 2 ? byte & 15 : byte >> 4];
}

// The packed kernels (AVX2 where the CPU has it, and the baseline one every CPU can run)
// compute Eq. 2 on the decoded values, inside the image and with clamped samples at its
// border, in both norms.
void packed_patch_cost_is_eq2_on_decoded_values(void **) {
    for (int dim : {128, 64}) {
        const DescriptorImage a = random_packed(20, 16, dim, 21), b = random_packed(20, 16, dim, 22);
        const PatchShape sub(3, 3);
        for (DescriptorNorm norm : {DescriptorNorm::L2, DescriptorNorm::L1})
            for (const auto &p : {std::array<int, 4>{8, 7, 11, 9}, std::array<int, 4>{1, 5, 0, 14}}) {
                const auto [ax, ay, bx, by] = p;
                double s = 0;
                for (int k = 0; k < sub.samples(); ++k) {
                    const int pax = std::clamp(ax + sub.dx[k], 0, 19), pay = std::clamp(ay + sub.dy[k], 0, 15);
                    const int pbx = std::clamp(bx + sub.dx[k], 0, 19), pby = std::clamp(by + sub.dy[k], 0, 15);
                    double e = 0;
                    for (int i = 0; i < dim; ++i) {
                        const int t = decoded(a, pax, pay, i) - decoded(b, pbx, pby, i);
                        e += norm == DescriptorNorm::L1 ? std::abs(t) : double(t) * t;
                    }
                    s += norm == DescriptorNorm::L1 ? e : std::sqrt(e);
                }
                near(patch_cost(a, b, ax, ay, bx, by, sub, norm, 1e9f), s);
                near(patch_cost_baseline_kernel(a.bits)(a, b, ax, ay, bx, by, sub, norm, 0.0f, 1e9f), s);
            }
    }
}

void out_of_image_costs_the_penalty(void **) {
    const DescriptorImage a = random_descriptors(20, 16, 16, 3), b = random_descriptors(20, 16, 16, 4);
    const PatchShape sub(3, 3);
    near(patch_cost(a, b, 5, 5, -1, 5, sub, DescriptorNorm::L2, 77.0f), 9 * 77.0);
    near(patch_cost(a, b, 5, 5, 5, 16, sub, DescriptorNorm::L2, 77.0f), 9 * 77.0);
    // Centre inside but patch crossing the border: samples are clamped, not penalised.
    double s = 0;
    for (int dy = -3; dy <= 3; dy += 3)
        for (int dx = -3; dx <= 3; dx += 3)
            s += descriptor_distance(a.at(std::max(0, 1 + dx), 5 + dy), b.at(std::max(0, 0 + dx), 5 + dy), 16,
                                     DescriptorNorm::L2);
    near(patch_cost(a, b, 1, 5, 0, 5, sub, DescriptorNorm::L2, 1e9f), s);
    // Early exit returns a partial sum above the bound.
    const float full = patch_cost(a, b, 9, 8, 10, 8, sub, DescriptorNorm::L2, 1e9f);
    const float part = patch_cost(a, b, 9, 8, 10, 8, sub, DescriptorNorm::L2, 1e9f, full / 4);
    assert_true(part > full / 4 && part <= full);
}

void four_cases_follow_the_paper(void **) {
    Four f{random_descriptors(40, 24, 32, 10), random_descriptors(40, 24, 32, 11), random_descriptors(40, 24, 32, 12),
           random_descriptors(40, 24, 32, 13)};
    const PatchShape full(3, 1);
    const int x = 20, y = 11, u = 3, v = -2, d0 = 6, d1 = 9;
    // Positions of Eqs. 4-6, 8-9, 11.
    const double E_l0l1 = reference_E(f.l0, f.l1, x, y, x + u, y + v);
    const double E_l0r0 = reference_E(f.l0, f.r0, x, y, x - d0, y);
    const double E_l0r1 = reference_E(f.l0, f.r1, x, y, x + u - d1, y + v);
    const double E_r0r1 = reference_E(f.r0, f.r1, x - d0, y, x + u - d1, y + v);
    const double E_r0l1 = reference_E(f.r0, f.l1, x - d0, y, x + u, y + v);
    const double E_l1r1 = reference_E(f.l1, f.r1, x + u, y + v, x + u - d1, y + v);
    const SlotDescriptors s = f.slots();
    auto C = [&](CostCase c) { return case_cost(s, c, x, y, u, v, d0, d1, full, DescriptorNorm::L2, 1e9f); };
    near(C(CostCase::Image), (E_l0l1 + E_l0r0 + E_l0r1) / 3);                       // Eq. 3
    near(C(CostCase::LidarD0), (E_l0l1 + E_l0r1 + E_r0r1 + E_r0l1) / 4);            // Eq. 7
    near(C(CostCase::LidarD1), (E_l0l1 + E_l0r0 + E_r0r1 + E_l1r1) / 4);            // Eq. 10
    near(C(CostCase::LidarD0D1), (E_l0l1 + E_r0l1 + 2 * E_r0r1 + E_l1r1) / 5);      // Eq. 12
    // The cases differ (the test would notice a swapped term).
    assert_true(std::abs(C(CostCase::LidarD0) - C(CostCase::LidarD1)) > 1.0);

    // Reference-anchored D_l^1 cases: E(l1, r1) replaced by E(l0, r1); C_I and C_{D_l^0} as is.
    auto A = [&](CostCase c) {
        return case_cost(s, c, x, y, u, v, d0, d1, full, DescriptorNorm::L2, 1e9f, D1Terms::ReferenceAnchored);
    };
    near(A(CostCase::Image), C(CostCase::Image));
    near(A(CostCase::LidarD0), C(CostCase::LidarD0));
    near(A(CostCase::LidarD1), (E_l0l1 + E_l0r0 + E_l0r1 + E_r0r1) / 4);
    near(A(CostCase::LidarD0D1), (E_l0l1 + E_r0l1 + 2 * E_r0r1 + E_l0r1) / 5);
    assert_true(std::abs(A(CostCase::LidarD1) - C(CostCase::LidarD1)) > 1.0);
    for (int c = 0; c < 4; ++c) {
        float sum = 0;
        for (int t = 0; t < kNumTerms; ++t) sum += case_weights(CostCase(c), D1Terms::ReferenceAnchored)[t];
        near(sum, kCaseWeightSum[c]);
        // No anchored case compares two target patches (the t1 stereo term).
        assert_true(case_weights(CostCase(c), D1Terms::ReferenceAnchored)[kTl1r1] == 0);
    }
}

void case_cost_validates(void **) {
    Four f{random_descriptors(10, 10, 16, 1), random_descriptors(10, 10, 16, 2), random_descriptors(10, 10, 16, 3),
           random_descriptors(12, 10, 16, 4)};
    SlotDescriptors s = f.slots();
    try {
        case_cost(s, CostCase::Image, 5, 5, 0, 0, 0, 0, PatchShape(3, 3), DescriptorNorm::L2, 1);
        fail_msg("size mismatch accepted");
    } catch (const Error &e) {
        assert_int_equal(int(e.code()), int(ErrorCode::InvalidArgument));
    }
    s.image[kR1] = nullptr;
    try {
        case_cost(s, CostCase::Image, 5, 5, 0, 0, 0, 0, PatchShape(3, 3), DescriptorNorm::L2, 1);
        fail_msg("missing slot accepted");
    } catch (const Error &e) {
        assert_int_equal(int(e.code()), int(ErrorCode::InvalidArgument));
    }
}

// A 160x96 synthetic scene with its LiDAR, and the full LiDAR-Flow options with a pyramid
// level below it.
synth::SynthScene small_scene(uint64_t seed) {
    synth::SynthConfig sc;
    sc.width = 160;
    sc.height = 96;
    sc.seed = seed;
    sc.threads = 1;
    return synth::render(sc);
}

MatchInput input_of(const synth::SynthScene &s) {
    return MatchInput{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
}

MatchingOptions small_scene_options() {
    MatchingOptions o = MatchingOptions::for_variant(MatchVariant::Full);
    o.min_coarsest_height = 24;
    return o;
}

// Every seed's reported cost is the case formula of its reported case at its match, and the
// case follows the LiDAR rules: D0 part for LiDAR pixels (and, with const1, window seeds).
void matcher_costs_are_the_case_formulas_for(D1Terms terms) {
    const synth::SynthScene scene = small_scene(5);
    const MatchInput in = input_of(scene);
    MatchingOptions o = small_scene_options();
    o.d1_terms = terms;
    const MatchResult r = match_scene_flow(in, o, Direction::Forward);

    Four f;
    f.l0 = features::compute_dense_sift(features::to_gray_float(scene.left0), o.sift);
    f.r0 = features::compute_dense_sift(features::to_gray_float(scene.right0), o.sift);
    f.l1 = features::compute_dense_sift(features::to_gray_float(scene.left1), o.sift);
    f.r1 = features::compute_dense_sift(features::to_gray_float(scene.right1), o.sift);
    const SlotDescriptors s = f.slots();
    const PatchShape shape(o.patch_radius, o.patch_step);
    auto rnd = [](float a) { return int(a + (a >= 0 ? 0.5f : -0.5f)); };
    int counts[4] = {0, 0, 0, 0};
    for (const SeedMatch &m : r.seeds) {
        const int u = rnd(m.u), v = rnd(m.v), d0 = rnd(m.d0), d1 = rnd(m.d1);
        const double expect = case_cost(s, m.cost_case, m.x, m.y, u, v, d0, d1, shape, o.norm, o.out_of_image_penalty,
                                        terms);
        near(m.cost, expect);
        const bool d0case = m.cost_case == CostCase::LidarD0 || m.cost_case == CostCase::LidarD0D1;
        assert_int_equal(d0case, m.is_lidar || m.in_window);
        counts[int(m.cost_case)]++;
    }
    // The scene exercises all four cases.
    for (int c = 0; c < 4; ++c) assert_true(counts[c] > 0);
}

// The matcher scores with the formulas its options select: the paper's Eqs. 10 / 12 (default)
// and the reference-anchored D_l^1 cases.
void matcher_costs_are_the_case_formulas(void **) {
    assert_int_equal(int(MatchingOptions{}.d1_terms), int(D1Terms::Paper));
    matcher_costs_are_the_case_formulas_for(D1Terms::Paper);
    matcher_costs_are_the_case_formulas_for(D1Terms::ReferenceAnchored);
}

// 128-byte 8-bit descriptors with the Euclidean distance (every preset's) take a kernel that
// computes three samples at a time. Its costs equal the one-sample loop's bit for bit (the
// baseline kernel's, which keeps that loop), and its early exit returns a partial sum above
// the bound exactly when the full cost is above it, for sample counts that are and are not
// multiples of three.
void byte_kernel_equals_the_one_sample_loop(void **) {
    const DescriptorImage a = random_descriptors(24, 20, 128, 31), b = random_descriptors(24, 20, 128, 32);
    const PatchCostFn fast = patch_cost_kernel(8), base = patch_cost_baseline_kernel(8);
    const float inf = std::numeric_limits<float>::infinity();
    for (const PatchShape &shape : {PatchShape(3, 3), PatchShape(2, 1), PatchShape(4, 2), PatchShape(0, 1)})
        for (const auto &p : {std::array<int, 4>{8, 7, 11, 9}, std::array<int, 4>{12, 10, 9, 12}}) {
            const auto [ax, ay, bx, by] = p;
            const float full = base(a, b, ax, ay, bx, by, shape, DescriptorNorm::L2, 1e9f, inf);
            double s = 0;
            for (int k = 0; k < shape.samples(); ++k)
                s += descriptor_distance(a.at(ax + shape.dx[k], ay + shape.dy[k]),
                                         b.at(bx + shape.dx[k], by + shape.dy[k]), 128, DescriptorNorm::L2);
            near(full, s);
            const float got = fast(a, b, ax, ay, bx, by, shape, DescriptorNorm::L2, 1e9f, inf);
            if (got != full) fail_msg("%d samples: %.9g != %.9g", shape.samples(), double(got), double(full));
            for (double frac : {0.05, 0.3, 0.5, 0.7, 0.95, 1.0, 1.2}) {
                const float bound = static_cast<float>(frac * full);
                const float partial = fast(a, b, ax, ay, bx, by, shape, DescriptorNorm::L2, 1e9f, bound);
                if (full > bound) {
                    assert_true(partial > bound && partial <= full);
                    assert_true(base(a, b, ax, ay, bx, by, shape, DescriptorNorm::L2, 1e9f, bound) > bound);
                } else {
                    assert_true(partial == full);
                }
            }
        }
}

// Remembering the candidates a seed tried (MatchingOptions::remember_tried) skips work but
// changes no result: the same matches and costs in both directions, with the LiDAR cases.
void remembering_tried_candidates_changes_nothing(void **) {
    const synth::SynthScene scene = small_scene(7);
    const MatchInput in = input_of(scene);
    MatchingOptions on = small_scene_options();
    assert_true(on.remember_tried);
    MatchingOptions off = on;
    off.remember_tried = false;
    for (Direction dir : {Direction::Forward, Direction::Backward}) {
        const MatchResult a = match_scene_flow(in, on, dir), b = match_scene_flow(in, off, dir);
        assert_true(a.tried_skips > 0);
        assert_int_equal(b.tried_skips, 0);
        assert_int_equal(a.seeds.size(), b.seeds.size());
        for (size_t i = 0; i < a.seeds.size(); ++i) {
            const SeedMatch &p = a.seeds[i], &q = b.seeds[i];
            if (p.u != q.u || p.v != q.v || p.d0 != q.d0 || p.d1 != q.d1 || p.cost != q.cost ||
                p.cost_case != q.cost_case)
                fail_msg("seed %zu differs: (%g %g %g %g, %g) vs (%g %g %g %g, %g)", i, p.u, p.v, p.d0, p.d1,
                         p.cost, q.u, q.v, q.d0, q.d1, q.cost);
        }
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(patch_distance_matches_eq2),
        cmocka_unit_test(packed_patch_cost_is_eq2_on_decoded_values),
        cmocka_unit_test(out_of_image_costs_the_penalty),
        cmocka_unit_test(four_cases_follow_the_paper),
        cmocka_unit_test(case_cost_validates),
        cmocka_unit_test(matcher_costs_are_the_case_formulas),
        cmocka_unit_test(byte_kernel_equals_the_one_sample_loop),
        cmocka_unit_test(remembering_tried_candidates_changes_nothing),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
