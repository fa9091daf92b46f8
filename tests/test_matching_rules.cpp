// SPDX-License-Identifier: MIT
// LiDAR rules of the matcher (a LiDAR pixel's d0 is never replaced; constraint 2 bounds d0 in
// D_l^0 windows and d1 for targets in D_l^1 windows), the ablation switches, determinism and
// input validation. Small synthetic scenes keep it fast.
#include <cmath>
#include <functional>
#include <limits>

#include "core/error.hpp"
#include "eval/metrics.hpp"
#include "matching/lidar_support.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "synth/scene.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::matching;

namespace {

const synth::SynthScene &scene() {
    static const synth::SynthScene s = [] {
        synth::SynthConfig c;
        c.width = 192;
        c.height = 96;
        c.seed = 7;
        c.threads = 1;
        c.lidar_points = 60;
        return synth::render(c);
    }();
    return s;
}

MatchInput input() {
    const auto &s = scene();
    return {s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
}

MatchingOptions small(MatchVariant v) {
    MatchingOptions o = MatchingOptions::for_variant(v);
    o.min_coarsest_height = 24;
    return o;
}

// Nearest point (Euclidean) among those whose window (Chebyshev radius r) holds (x, y).
int nearest_in_window(const std::vector<LidarPoint> &pts, int x, int y, int r) {
    int best = -1;
    double bd = std::numeric_limits<double>::infinity();
    for (int k = 0; k < int(pts.size()); ++k) {
        if (std::abs(pts[k].x - x) > r || std::abs(pts[k].y - y) > r) continue;
        const double d = std::hypot(pts[k].x - x, pts[k].y - y);
        if (d < bd) {
            bd = d;
            best = k;
        }
    }
    return best;
}

bool within_interval(float d, float value, const MatchingOptions &o) {
    const float hw = std::max(o.const2_abs, o.const2_rel * value);
    return d >= std::max(0.0f, value - hw) - 1e-3f && d <= value + hw + 1e-3f;
}

void lidar_d0_is_never_replaced(void **) {
    for (Direction dir : {Direction::Forward, Direction::Backward}) {
        const MatchResult r = match_scene_flow(input(), small(MatchVariant::Full), dir);
        const auto &pts = dir == Direction::Forward ? scene().lidar0.points : scene().lidar1.points;
        int lidar_seeds = 0;
        for (const SeedMatch &m : r.seeds) {
            if (!m.is_lidar) continue;
            ++lidar_seeds;
            const int k = nearest_in_window(pts, m.x, m.y, 0);
            assert_true(k >= 0);
            assert_true(m.d0 == pts[k].disparity);
        }
        assert_int_equal(lidar_seeds, int(pts.size()));
        // ... and each LiDAR pixel keeps its own match in the dense output.
        for (const LidarPoint &p : pts) assert_true(r.dense.d0(p.y, p.x) == p.disparity);
    }
}

void constraint2_bounds_disparities_in_windows(void **) {
    const MatchingOptions o = small(MatchVariant::Full);
    const MatchResult r = match_scene_flow(input(), o, Direction::Forward);
    const auto &p0 = scene().lidar0.points, &p1 = scene().lidar1.points;
    const int rad = o.window_size / 2;
    int d0_checked = 0, d1_checked = 0;
    for (const SeedMatch &m : r.seeds) {
        const int k0 = nearest_in_window(p0, m.x, m.y, rad);
        assert_int_equal(m.in_window, k0 >= 0);
        if (k0 >= 0) {
            assert_true(within_interval(m.d0, p0[k0].disparity, o));
            ++d0_checked;
        }
        const int tx = int(std::lround(m.x + m.u)), ty = int(std::lround(m.y + m.v));
        const int k1 = nearest_in_window(p1, tx, ty, rad);
        if (k1 >= 0) {
            assert_true(within_interval(m.d1, p1[k1].disparity, o));
            ++d1_checked;
        }
    }
    assert_true(d0_checked > 100);
    assert_true(d1_checked > 50);

    // Without constraint 2 the same scene leaves some window seed outside the interval: the
    // bound above is the constraint's doing, not the scene's.
    const MatchingOptions o1 = small(MatchVariant::ImLidarWinConst1);
    const MatchResult r1 = match_scene_flow(input(), o1, Direction::Forward);
    int outside = 0;
    for (const SeedMatch &m : r1.seeds) {
        const int k0 = nearest_in_window(p0, m.x, m.y, rad);
        if (k0 >= 0 && !m.is_lidar && !within_interval(m.d0, p0[k0].disparity, o)) ++outside;
    }
    assert_true(outside > 0);
}

void image_only_ignores_lidar(void **) {
    const MatchResult r = match_scene_flow(input(), small(MatchVariant::ImageOnly), Direction::Forward);
    assert_int_equal(int(r.seeds.size()), r.grid_width * r.grid_height);
    for (const SeedMatch &m : r.seeds) {
        assert_false(m.is_lidar);
        assert_false(m.in_window);
        assert_int_equal(int(m.cost_case), int(CostCase::Image));
    }
    // Dense, 100 %.
    assert_int_equal(cv::countNonZero(r.dense.valid), 192 * 96);
}

bool same_field(const SceneFlowField &a, const SceneFlowField &b) {
    for (const auto &[x, y] : {std::pair{&a.u, &b.u}, {&a.v, &b.v}, {&a.d0, &b.d0}, {&a.d1, &b.d1}})
        if (cv::norm(*x, *y, cv::NORM_INF) != 0) return false;
    return true;
}

void deterministic(void **) {
    MatchingOptions o = small(MatchVariant::Full);
    o.threads = 1;
    const MatchResult a = match_scene_flow(input(), o, Direction::Forward);
    const MatchResult b = match_scene_flow(input(), o, Direction::Forward);
    assert_true(same_field(a.dense, b.dense));
    o.threads = 3;  // strips are the unit of parallel work: thread count does not matter
    const MatchResult c = match_scene_flow(input(), o, Direction::Forward);
    assert_true(same_field(a.dense, c.dense));
    o.random_seed = 99;  // ... while the random seed does
    const MatchResult d = match_scene_flow(input(), o, Direction::Forward);
    assert_false(same_field(a.dense, d.dense));
}

// Share of pixels with a KITTI flow outlier against the scene's ground truth.
double flow_outlier_pct(const SceneFlowField &est) {
    const FlowField &gt = scene().flow_occ;
    long n = 0, bad = 0;
    for (int y = 0; y < est.height(); ++y)
        for (int x = 0; x < est.width(); ++x) {
            if (!gt.valid(y, x)) continue;
            ++n;
            bad += eval::flow_outlier(gt.u(y, x), gt.v(y, x), est.u(y, x), est.v(y, x)) ? 1 : 0;
        }
    return 100.0 * bad / std::max(1L, n);
}

// Coarse levels with every 2nd (4th) seed per axis: the LiDAR rules hold, results do not
// depend on the thread count, and the match is about as good as with every seed.
void thinned_coarse_levels(void **) {
    MatchingOptions every = small(MatchVariant::Full);
    every.thin_from_level = 100;
    MatchingOptions thin = every;
    thin.thin_from_level = 1;  // strides 2 and 4 on the 1/2 and 1/4 levels ...
    // ... which the default floor of seeds per level forbids on this small image:
    assert_true(same_field(match_scene_flow(input(), thin, Direction::Forward).dense,
                           match_scene_flow(input(), every, Direction::Forward).dense));
    thin.min_level_seeds = 1;
    thin.threads = 1;
    const MatchResult a = match_scene_flow(input(), thin, Direction::Forward);
    thin.threads = 3;
    assert_true(same_field(a.dense, match_scene_flow(input(), thin, Direction::Forward).dense));
    const MatchResult full = match_scene_flow(input(), every, Direction::Forward);
    assert_false(same_field(a.dense, full.dense));  // the option does act
    for (const LidarPoint &p : scene().lidar0.points) assert_true(a.dense.d0(p.y, p.x) == p.disparity);
    const double thin_pct = flow_outlier_pct(a.dense), full_pct = flow_outlier_pct(full.dense);
    std::printf("flow outliers: every seed %.2f %%, thinned %.2f %%\n", full_pct, thin_pct);
    assert_true(thin_pct <= full_pct + 5.0);
    assert_true(thin_pct < 30.0);
}

// A LiDAR rule that moves the d0 of a propagated match moves its d1 by the same amount (it
// keeps its disparity change) unless keep_disparity_change is off; image-only matching has no
// LiDAR rule and no LiDAR case, so neither this nor d1_terms changes it.
void lidar_d0_rule_keeps_disparity_change(void **) {
    assert_true(d1_after_d0_rule(10.0f, 7.0f, 12.0f, true) == 15.0f);   // d0 +5: d1 +5
    assert_true(d1_after_d0_rule(10.0f, 7.0f, 4.5f, true) == 7.5f);     // d0 -2.5: d1 -2.5
    assert_true(d1_after_d0_rule(10.0f, 7.0f, 12.0f, false) == 10.0f);  // paper: d1 as is
    assert_true(d1_after_d0_rule(10.0f, 7.0f, 7.0f, true) == 10.0f);    // d0 not moved
    assert_true(MatchingOptions{}.keep_disparity_change);

    MatchingOptions on = small(MatchVariant::Full), off = on;
    off.keep_disparity_change = false;
    const MatchResult a = match_scene_flow(input(), on, Direction::Forward);
    const MatchResult b = match_scene_flow(input(), off, Direction::Forward);
    assert_false(same_field(a.dense, b.dense));  // the rule is applied in LiDAR mode

    MatchingOptions im = small(MatchVariant::ImageOnly), im_paper = im;
    im_paper.keep_disparity_change = false;
    im_paper.d1_terms = D1Terms::Paper;
    const MatchResult c = match_scene_flow(input(), im, Direction::Forward);
    const MatchResult d = match_scene_flow(input(), im_paper, Direction::Forward);
    assert_true(same_field(c.dense, d.dense));
}

void expect_error(ErrorCode code, const std::function<void()> &fn) {
    try {
        fn();
        fail_msg("expected lidarflow::Error");
    } catch (const Error &e) {
        assert_int_equal(int(e.code()), int(code));
    }
}

// The backward direction may use a coarser seed grid (it only serves the round-trip check):
// the forward direction is untouched, the backward one has the coarser grid, keeps the t1
// LiDAR rules and the thread independence, and its own step equal to grid_step changes nothing.
void backward_grid_step(void **) {
    MatchingOptions base = small(MatchVariant::Full);
    MatchingOptions coarse = base;
    coarse.backward_grid_step = 6;
    assert_true(same_field(match_scene_flow(input(), base, Direction::Forward).dense,
                           match_scene_flow(input(), coarse, Direction::Forward).dense));
    const MatchResult fine = match_scene_flow(input(), base, Direction::Backward);
    coarse.threads = 1;
    const MatchResult a = match_scene_flow(input(), coarse, Direction::Backward);
    coarse.threads = 3;
    assert_true(same_field(a.dense, match_scene_flow(input(), coarse, Direction::Backward).dense));
    assert_int_equal(fine.grid_width, scene().left0.cols / base.grid_step);
    assert_int_equal(a.grid_width, scene().left0.cols / 6);
    assert_int_equal(a.grid_height, scene().left0.rows / 6);
    for (const LidarPoint &p : scene().lidar1.points) assert_true(a.dense.d0(p.y, p.x) == p.disparity);
    MatchingOptions same = base;
    same.backward_grid_step = base.grid_step;
    assert_true(same_field(fine.dense, match_scene_flow(input(), same, Direction::Backward).dense));
    MatchingOptions bad = base;
    bad.backward_grid_step = -1;
    expect_error(ErrorCode::InvalidArgument, [&] { bad.validate(); });
    bad.backward_grid_step = 33;
    expect_error(ErrorCode::InvalidArgument, [&] { bad.validate(); });
}

void validates_input(void **) {
    const MatchingOptions o = small(MatchVariant::Full);
    expect_error(ErrorCode::SizeMismatch, [&] {
        MatchInput in = input();
        in.right1 = in.right1(cv::Rect(0, 0, 100, 96)).clone();
        SceneFlowMatcher m(in, o);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchInput in = input();
        in.left1 = cv::Mat();
        SceneFlowMatcher m(in, o);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchInput in = input();
        in.left0.convertTo(in.left0, CV_16U);
        SceneFlowMatcher m(in, o);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchInput in = input();
        in.lidar0.points.push_back({192, 5, 10.0f});  // outside
        SceneFlowMatcher m(in, o);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchInput in = input();
        in.lidar1.points.push_back({5, 5, std::numeric_limits<float>::quiet_NaN()});
        SceneFlowMatcher m(in, o);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchInput in = input();
        in.lidar0.points.push_back({5, 5, -2.0f});
        SceneFlowMatcher m(in, o);
    });
    expect_error(ErrorCode::SizeMismatch, [&] {
        MatchInput in = input();
        in.lidar0.width = 100;
        SceneFlowMatcher m(in, o);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchingOptions bad = o;
        bad.support_window = false;  // const1/const2 act inside windows
        SceneFlowMatcher m(input(), bad);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchingOptions bad = o;
        bad.window_size = 14;
        SceneFlowMatcher m(input(), bad);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchingOptions bad = o;
        bad.thin_from_level = 0;  // the full-resolution level always has every seed
        SceneFlowMatcher m(input(), bad);
    });
    expect_error(ErrorCode::InvalidArgument, [&] {
        MatchingOptions bad = o;
        bad.max_disparity = std::numeric_limits<float>::infinity();
        SceneFlowMatcher m(input(), bad);
    });
    // Empty LiDAR is fine in LiDAR mode (nothing to support with).
    MatchInput none = input();
    none.lidar0 = {};
    none.lidar1 = {};
    const MatchResult r = match_scene_flow(none, o, Direction::Forward);
    for (const SeedMatch &m : r.seeds) assert_false(m.is_lidar);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lidar_d0_is_never_replaced),
        cmocka_unit_test(constraint2_bounds_disparities_in_windows),
        cmocka_unit_test(image_only_ignores_lidar),
        cmocka_unit_test(deterministic),
        cmocka_unit_test(thinned_coarse_levels),
        cmocka_unit_test(lidar_d0_rule_keeps_disparity_change),
        cmocka_unit_test(backward_grid_step),
        cmocka_unit_test(validates_input),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
