// SPDX-License-Identifier: MIT
// Stage 4 (src/interpolation): the robust interpolator on an exactly piecewise-planar scene,
// LiDAR anchoring, very few and very many matches, degenerate input, determinism.
#include "test_support.hpp"

#include <cmath>
#include <fstream>
#include <cstdio>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "interpolation/interpolator.hpp"
#include "interpolation_scene.hpp"

using namespace lidarflow;
using test::expect_error;
using lidarflow::test::outlier_rates;

namespace {

bool all_finite_and_valid(const SceneFlowField &f) {
    for (int y = 0; y < f.height(); ++y)
        for (int x = 0; x < f.width(); ++x) {
            if (!f.valid(y, x)) return false;
            for (const cv::Mat1f *m : {&f.u, &f.v, &f.d0, &f.d1})
                if (!std::isfinite((*m)(y, x))) return false;
            if (f.d0(y, x) < 0 || f.d1(y, x) < 0) return false;
        }
    return true;
}

void print_rates(const char *what, const test::OutlierRates &r) {
    std::printf("%s: D0 %.2f D1 %.2f Fl %.2f SF %.2f %% (EPE d0 %.3f, fl %.3f px)\n", what, r.d0, r.d1, r.fl,
                r.sf, r.epe_d0, r.epe_fl);
}

// 5 % matches, 5 % of them gross outliers, no LiDAR: the four planar regions come back.
void reproduces_piecewise_planar_scene(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    const SceneFlowField m = test::sample_matches(s.truth, 0.05, 0.05, 11);
    interpolation::InterpolationOptions o;
    o.use_lidar = false;
    const interpolation::InterpolationResult r = interpolation::RobustInterpolator(o).run(m, SparseLidar{}, s.image);
    assert_true(all_finite_and_valid(r.dense));
    const test::OutlierRates rate = outlier_rates(r.dense, s.truth);
    print_rates("planar scene", rate);
    assert_true(rate.sf < 3.0);
    assert_true(rate.epe_d0 < 0.5);
    assert_true(rate.epe_fl < 0.5);
    // Away from region boundaries, the planes are recovered almost exactly.
    cv::Mat1b interior(s.region.size(), uint8_t(0));
    for (int y = 4; y < s.region.rows - 4; ++y)
        for (int x = 4; x < s.region.cols - 4; ++x) {
            bool same = true;
            for (int dy = -4; dy <= 4; dy += 4)
                for (int dx = -4; dx <= 4; dx += 4) same = same && s.region(y + dy, x + dx) == s.region(y, x);
            interior(y, x) = same;
        }
    const test::OutlierRates in = outlier_rates(r.dense, s.truth, interior);
    print_rates("interior", in);
    assert_true(in.sf < 1.0);
    assert_true(in.epe_d0 < 0.02);
}

// LiDAR grid of exact d0 measurements (every `step` px), also entered as exact matches.
SparseLidar lidar_grid(const SceneFlowField &truth, SceneFlowField &matches, int step) {
    SparseLidar l;
    l.width = truth.width();
    l.height = truth.height();
    for (int y = step / 2; y < truth.height(); y += step)
        for (int x = step / 2; x < truth.width(); x += step) {
            l.points.push_back({x, y, truth.d0(y, x)});
            matches.u(y, x) = truth.u(y, x);
            matches.v(y, x) = truth.v(y, x);
            matches.d0(y, x) = truth.d0(y, x);
            matches.d1(y, x) = truth.d1(y, x);
            matches.valid(y, x) = 1;
        }
    return l;
}

// Every LiDAR pixel's output d0 is its measurement: exactly with keep_lidar_values, within
// the rejection tolerance from the models alone - even where the measurement contradicts all
// matches around it (the matches say truth, one LiDAR point says truth + 5 px).
void lidar_anchors_are_honoured(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    SceneFlowField m = test::sample_matches(s.truth, 0.05, 0.05, 12);
    SparseLidar lidar = lidar_grid(s.truth, m, 40);
    const int odd = 20;  // (180, 100): ground region interior
    assert_int_equal(lidar.points[odd].x, 180);
    assert_int_equal(lidar.points[odd].y, 100);
    lidar.points[odd].disparity += 5.0f;

    interpolation::InterpolationOptions o;
    o.keep_lidar_values = true;
    const interpolation::InterpolationResult exact = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    for (const LidarPoint &p : lidar.points) assert_float_equal(exact.dense.d0(p.y, p.x), p.disparity, 1e-6);
    assert_true(exact.lidar_anchored_geometry >= static_cast<int>(lidar.points.size()));

    o.keep_lidar_values = false;
    const interpolation::InterpolationResult model = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    for (const LidarPoint &p : lidar.points)
        assert_true(std::fabs(model.dense.d0(p.y, p.x) - p.disparity) <= o.lidar_disparity_tolerance + 1e-4f);

    o.use_lidar = false;
    const interpolation::InterpolationResult off = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    const LidarPoint &p = lidar.points[odd];
    std::printf("contradicting LiDAR: on %.3f, off %.3f, truth %.3f, LiDAR %.3f\n", model.dense.d0(p.y, p.x),
                off.dense.d0(p.y, p.x), s.truth.d0(p.y, p.x), p.disparity);
    assert_true(std::fabs(off.dense.d0(p.y, p.x) - s.truth.d0(p.y, p.x)) < 0.5f);
    assert_int_equal(off.lidar_anchored_geometry, 0);
}

// Stage 4's work on its image computed ahead (prepare_image) gives run()'s results bit for bit
// and is taken as it is: with sparse points its superpixels and edges, with a dense scan (whose
// superpixels follow the scan) its edges only. Another image's or another size's is not used.
void image_work_computed_ahead(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    SceneFlowField ms = test::sample_matches(s.truth, 0.05, 0.05, 12);
    SceneFlowField md = test::sample_matches(s.truth, 0.05, 0.05, 12);
    interpolation::InterpolationOptions a;
    a.superpixels.region_size = 20;
    a.lidar_points_per_superpixel = 2;
    a.num_threads = 2;
    const SparseLidar sparse = lidar_grid(s.truth, ms, 40), dense = lidar_grid(s.truth, md, 4);
    const interpolation::RobustInterpolator ip(a);
    const auto same = [](const interpolation::InterpolationResult &x, const interpolation::InterpolationResult &y) {
        const cv::Mat1f *fx[] = {&x.dense.u, &x.dense.v, &x.dense.d0, &x.dense.d1, &x.dense.confidence, &x.edges};
        const cv::Mat1f *fy[] = {&y.dense.u, &y.dense.v, &y.dense.d0, &y.dense.d1, &y.dense.confidence, &y.edges};
        for (int i = 0; i < 6; ++i)
            if (cv::norm(*fx[i], *fy[i], cv::NORM_INF) != 0) return false;
        return x.num_superpixels == y.num_superpixels && cv::countNonZero(x.superpixels != y.superpixels) == 0;
    };
    for (const bool scan : {false, true}) {
        const SceneFlowField &m = scan ? md : ms;
        const SparseLidar &lidar = scan ? dense : sparse;
        const interpolation::InterpolationResult plain = ip.run(m, lidar, s.image);
        const interpolation::ImageWork w = ip.prepare_image(s.image, lidar.points.size());
        assert_int_equal(w.region_size, plain.superpixel_size);
        assert_true((w.superpixels == nullptr) == scan);
        const interpolation::InterpolationResult ahead = ip.run(m, lidar, s.image, {}, {}, {}, 0, &w);
        assert_true(same(ahead, plain));
        assert_true(ahead.edges.data == w.edges.data);  // taken, not computed again
        if (!scan) assert_true(ahead.superpixels.data == w.superpixels->labels.data);
    }
    cv::Mat other = s.image.clone();
    other.ptr<uint8_t>(80)[100] ^= 0x40;
    const interpolation::ImageWork of_other = ip.prepare_image(other, sparse.points.size());
    const interpolation::ImageWork of_scan = ip.prepare_image(s.image, dense.points.size());
    const interpolation::InterpolationResult plain = ip.run(ms, sparse, s.image);
    for (const interpolation::ImageWork *w : {&of_other, &of_scan}) {
        const interpolation::InterpolationResult r = ip.run(ms, sparse, s.image, {}, {}, {}, 0, w);
        assert_true(same(r, plain));
        assert_true(r.edges.data != w->edges.data);
    }
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { ip.prepare_image(cv::Mat(), 0); }));
}

// The superpixel size follows the LiDAR's density between min_superpixel_size and region_size:
// sparse points (or none, or the rule off) keep region_size; run() reports the size it used.
void superpixels_shrink_with_dense_lidar(void **) {
    interpolation::InterpolationOptions o;
    o.superpixels.region_size = 20;
    const cv::Size image(400, 100);  // 40000 px
    assert_int_equal(interpolation::superpixel_size(o, 20000, image), 20);  // off by default
    o.lidar_points_per_superpixel = 2;
    assert_int_equal(interpolation::superpixel_size(o, 0, image), 20);
    assert_int_equal(interpolation::superpixel_size(o, 88, image), 20);      // 30 px
    assert_int_equal(interpolation::superpixel_size(o, 320, image), 16);     // 2 points per 16 x 16 px
    assert_int_equal(interpolation::superpixel_size(o, 20000, image), 10);  // 2 px: the floor
    o.min_superpixel_size = 40;  // a floor above the largest size: the largest
    assert_int_equal(interpolation::superpixel_size(o, 20000, image), 20);
    // Smaller superpixels draw initial hypotheses in proportion to their area, at least 4.
    assert_int_equal(interpolation::initial_hypotheses(24, 20, 20), 24);
    assert_int_equal(interpolation::initial_hypotheses(24, 10, 20), 6);
    assert_int_equal(interpolation::initial_hypotheses(24, 10, 16), 9);
    assert_int_equal(interpolation::initial_hypotheses(24, 4, 20), interpolation::kMinInitialHypotheses);
    assert_int_equal(interpolation::initial_hypotheses(2, 10, 20), 2);  // never more than asked

    const test::PlanarScene s = test::make_planar_scene();
    SceneFlowField ms = test::sample_matches(s.truth, 0.05, 0.05, 12), md = test::sample_matches(s.truth, 0.05, 0.05, 12);
    interpolation::InterpolationOptions a;
    a.superpixels.region_size = 20;
    a.lidar_points_per_superpixel = 2;
    const SparseLidar sparse = lidar_grid(s.truth, ms, 40), dense = lidar_grid(s.truth, md, 4);
    const interpolation::InterpolationResult rs = interpolation::RobustInterpolator(a).run(ms, sparse, s.image);
    const interpolation::InterpolationResult rd = interpolation::RobustInterpolator(a).run(md, dense, s.image);
    assert_int_equal(rs.superpixel_size, 20);
    assert_int_equal(rd.superpixel_size, interpolation::superpixel_size(a, dense.points.size(), s.image.size()));
    assert_true(rd.superpixel_size < 20 && rd.num_superpixels > rs.num_superpixels);

    // The depth term (superpixels.disparity_weight, over the geometry hint) moves a dense scan's
    // superpixels only: the sparse size keeps the colour-only segmentation.
    interpolation::InterpolationOptions depth = a;
    depth.superpixels.disparity_weight = 64.0f;
    const DisparityMap hint = s.truth.d0.clone();
    const auto same = [](const interpolation::InterpolationResult &x, const interpolation::InterpolationResult &y) {
        return x.num_superpixels == y.num_superpixels && cv::countNonZero(x.superpixels != y.superpixels) == 0;
    };
    assert_true(same(interpolation::RobustInterpolator(depth).run(ms, sparse, s.image, hint),
                     interpolation::RobustInterpolator(a).run(ms, sparse, s.image, hint)));
    assert_false(same(interpolation::RobustInterpolator(depth).run(md, dense, s.image, hint),
                      interpolation::RobustInterpolator(a).run(md, dense, s.image, hint)));

    // Merged back on the scene's planes: fewer superpixels, the same accuracy.
    interpolation::InterpolationOptions merged = a;
    merged.planar_merge_tolerance = 0.3f;
    merged.merge_unseen = true;
    const interpolation::InterpolationResult rm = interpolation::RobustInterpolator(merged).run(md, dense, s.image);
    const auto d0_outliers = [&](const SceneFlowField &f) {
        return cv::countNonZero(cv::abs(f.d0 - s.truth.d0) > 1.0f) / static_cast<double>(f.d0.total());
    };
    std::printf("dense LiDAR: %d superpixels, D0 outliers %.4f; merged on planes: %d, %.4f\n", rd.num_superpixels,
                d0_outliers(rd.dense), rm.num_superpixels, d0_outliers(rm.dense));
    assert_true(rm.num_superpixels < rd.num_superpixels * 3 / 4);
    assert_true(d0_outliers(rm.dense) <= d0_outliers(rd.dense) + 0.005);
}

// A curved patch of ground (a 2.5 px bump of 14 px scale) under a dense scan: planes of 20 px
// cut through it; the points' residuals spread over their planes' pixels
// (lidar_residual_radius) give its shape back between the points, and change nothing where
// the planes already fit.
void lidar_residuals_follow_a_curved_surface(void **) {
    test::PlanarScene s = test::make_planar_scene();
    const int cx = 180, cy = 105;
    const auto bump = [&](int x, int y) {
        const float d2 = static_cast<float>((x - cx) * (x - cx) + (y - cy) * (y - cy));
        return 2.5f * std::exp(-d2 / (2.0f * 14.0f * 14.0f));
    };
    for (int y = 0; y < s.truth.height(); ++y)
        for (int x = 0; x < s.truth.width(); ++x)
            if (s.region(y, x) == 1) s.truth.d0(y, x) += bump(x, y);
    SceneFlowField m = test::sample_matches(s.truth, 0.05, 0.0, 14);
    const SparseLidar lidar = lidar_grid(s.truth, m, 4);
    interpolation::InterpolationOptions o;
    o.superpixels.region_size = 20;
    const interpolation::InterpolationResult planes = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    o.lidar_residual_radius = 3.0f;
    const interpolation::InterpolationResult spread = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    // Mean |d0 - truth| on the bump and on the rest of the ground, LiDAR pixels left out.
    const auto errors = [&](const SceneFlowField &f, double &on, double &off) {
        double e[2] = {0, 0};
        int n[2] = {0, 0};
        for (int y = 0; y < s.truth.height(); ++y)
            for (int x = 0; x < s.truth.width(); ++x) {
                if (s.region(y, x) != 1 || (x % 4 == 2 && y % 4 == 2)) continue;
                const int k = bump(x, y) > 0.5f ? 0 : 1;
                e[k] += std::fabs(f.d0(y, x) - s.truth.d0(y, x));
                ++n[k];
            }
        on = e[0] / n[0];
        off = e[1] / n[1];
    };
    double on0, off0, on1, off1;
    errors(planes.dense, on0, off0);
    errors(spread.dense, on1, off1);
    std::printf("curved ground, mean |d0 error|: planes %.3f on the bump / %.3f elsewhere; with the residuals "
                "%.3f / %.3f px\n", on0, off0, on1, off1);
    assert_true(on1 < 0.6 * on0);
    assert_true(off1 <= off0 + 0.01);
}

// A patch of the ground where matching failed coherently (every match there wrong the same
// way, as in a shadow): the superpixel holding a LiDAR point there is fixed with use_lidar
// (the wrong majority's models are rejected by the anchor) and stays wrong without.
void lidar_fixes_coherently_wrong_superpixel(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    SceneFlowField m = test::sample_matches(s.truth, 0.05, 0.0, 13);
    const int cx = 150, cy = 130, r = 14;
    for (int y = cy - r; y <= cy + r; ++y)
        for (int x = cx - r; x <= cx + r; ++x) {
            if (!m.valid(y, x) || (x - cx) * (x - cx) + (y - cy) * (y - cy) > r * r) continue;
            m.u(y, x) = s.truth.u(y, x) + 7.0f;
            m.v(y, x) = s.truth.v(y, x) - 4.0f;
            m.d0(y, x) = s.truth.d0(y, x) + 8.0f;
            m.d1(y, x) = s.truth.d1(y, x) + 8.0f;
        }
    SparseLidar lidar;
    lidar.width = s.truth.width();
    lidar.height = s.truth.height();
    lidar.points.push_back({cx, cy, s.truth.d0(cy, cx)});
    m.u(cy, cx) = s.truth.u(cy, cx);
    m.v(cy, cx) = s.truth.v(cy, cx);
    m.d0(cy, cx) = s.truth.d0(cy, cx);
    m.d1(cy, cx) = s.truth.d1(cy, cx);
    m.valid(cy, cx) = 1;

    interpolation::InterpolationOptions o;
    o.keep_lidar_values = false;
    // The scenario needs a neighbourhood the wrong matches dominate: with the default 256
    // neighbours the right matches around outvote them even without LiDAR.
    o.num_neighbors = 64;
    // Default: only geometry is anchored; the LiDAR point still fixes d0 of its superpixel.
    const interpolation::InterpolationResult geo_only = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    o.lidar_motion_anchors = true;  // the paper's rule: the LiDAR match anchors motion as well
    const interpolation::InterpolationResult on = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    o.use_lidar = false;
    const interpolation::InterpolationResult off = interpolation::RobustInterpolator(o).run(m, lidar, s.image);
    const cv::Mat1b mask = on.superpixels == on.superpixels(cy, cx);
    const test::OutlierRates ron = outlier_rates(on.dense, s.truth, mask);
    const test::OutlierRates roff = outlier_rates(off.dense, s.truth, mask);
    print_rates("LiDAR superpixel, use_lidar on ", ron);
    print_rates("LiDAR superpixel, use_lidar off", roff);
    assert_true(on.lidar_anchored_geometry >= 1 && on.lidar_anchored_motion >= 1);
    assert_true(ron.epe_d0 < 1.0 && ron.epe_fl < 1.5);
    assert_true(roff.epe_d0 > 4.0 && roff.epe_fl > 4.0);
    const test::OutlierRates rgeo = outlier_rates(geo_only.dense, s.truth, mask);
    print_rates("LiDAR superpixel, geometry only", rgeo);
    assert_true(geo_only.lidar_anchored_geometry >= 1 && geo_only.lidar_anchored_motion == 0);
    assert_true(rgeo.epe_d0 < 1.0);
}

// ~50 matches over 51k pixels (no outliers): every pixel gets a finite model and the large
// planar regions are still mostly right.
void works_with_very_few_matches(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    const SceneFlowField m = test::sample_matches(s.truth, 0.001, 0.0, 14);
    const int n = cv::countNonZero(m.valid);
    assert_true(n >= 30 && n <= 80);
    interpolation::InterpolationOptions o;
    const interpolation::InterpolationResult r = interpolation::RobustInterpolator(o).run(m, SparseLidar{}, s.image);
    assert_true(all_finite_and_valid(r.dense));
    const test::OutlierRates rate = outlier_rates(r.dense, s.truth);
    std::printf("%d matches: ", n);
    print_rates("", rate);
    assert_true(rate.sf < 15.0);

    // A single match: constant fields equal to it.
    SceneFlowField one = SceneFlowField::zeros(s.truth.width(), s.truth.height());
    one.u(50, 50) = 1.5f, one.v(50, 50) = -2.0f, one.d0(50, 50) = 12.0f, one.d1(50, 50) = 11.0f;
    one.valid(50, 50) = 1;
    const SceneFlowField d = interpolation::interpolate_scene_flow(one, SparseLidar{}, s.image, o);
    assert_true(all_finite_and_valid(d));
    for (int y = 0; y < d.height(); y += 7)
        for (int x = 0; x < d.width(); x += 7) {
            assert_float_equal(d.u(y, x), 1.5f, 1e-4);
            assert_float_equal(d.d0(y, x), 12.0f, 1e-4);
        }
}

// Degenerate input: every match on one image row (all 3-point subsets collinear), and two
// matches only. No NaN, no crash, values along the row right.
void handles_collinear_and_tiny_inputs(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    SceneFlowField m = SceneFlowField::zeros(s.truth.width(), s.truth.height());
    for (int x = 0; x < m.width(); x += 3) {
        m.u(100, x) = s.truth.u(100, x), m.v(100, x) = s.truth.v(100, x);
        m.d0(100, x) = s.truth.d0(100, x), m.d1(100, x) = s.truth.d1(100, x);
        m.valid(100, x) = 1;
    }
    interpolation::InterpolationOptions o;
    o.use_lidar = false;
    const interpolation::InterpolationResult r = interpolation::RobustInterpolator(o).run(m, SparseLidar{}, s.image);
    assert_true(all_finite_and_valid(r.dense));
    int good = 0, total = 0;
    for (int x = 0; x < m.width(); ++x) {
        ++total;
        good += std::fabs(r.dense.d0(100, x) - s.truth.d0(100, x)) < 1.0f;
    }
    assert_true(good > total * 8 / 10);

    SceneFlowField two = SceneFlowField::zeros(m.width(), m.height());
    two.valid(10, 10) = two.valid(150, 300) = 1;
    two.d0(10, 10) = 5, two.d0(150, 300) = 30;
    const SceneFlowField d = interpolation::interpolate_scene_flow(two, SparseLidar{}, s.image, o);
    assert_true(all_finite_and_valid(d));
}

// Every pixel a match (51k matches, 2 % gross outliers): near-exact result.
void works_with_dense_matches(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    const SceneFlowField m = test::sample_matches(s.truth, 1.0, 0.02, 15);
    interpolation::InterpolationOptions o;
    o.num_threads = 2;
    const interpolation::InterpolationResult r = interpolation::RobustInterpolator(o).run(m, SparseLidar{}, s.image);
    assert_true(all_finite_and_valid(r.dense));
    const test::OutlierRates rate = outlier_rates(r.dense, s.truth);
    print_rates("dense matches", rate);
    assert_true(rate.sf < 0.5);
}

bool same_field(const SceneFlowField &a, const SceneFlowField &b) {
    for (const auto &[x, y] : {std::pair(&a.u, &b.u), std::pair(&a.v, &b.v), std::pair(&a.d0, &b.d0),
                               std::pair(&a.d1, &b.d1), std::pair(&a.confidence, &b.confidence)})
        if (cv::norm(*x, *y, cv::NORM_INF) != 0.0) return false;
    return true;
}

// Same input, same output, bit for bit, on 1 and 3 threads; another seed may differ.
void deterministic_for_any_thread_count(void **) {
    const test::PlanarScene s = test::make_planar_scene();
    SceneFlowField m = test::sample_matches(s.truth, 0.05, 0.1, 16);
    const SparseLidar lidar = lidar_grid(s.truth, m, 50);
    interpolation::InterpolationOptions o;
    o.num_threads = 1;
    const interpolation::RobustInterpolator one(o);
    o.num_threads = 3;
    const interpolation::RobustInterpolator three(o);
    const SceneFlowField a = one.run(m, lidar, s.image).dense;
    const SceneFlowField b = three.run(m, lidar, s.image).dense;
    const SceneFlowField c = one.run(m, lidar, s.image).dense;
    assert_true(same_field(a, b));
    assert_true(same_field(a, c));
}

void rejects_invalid_input(void **) {
    const test::PlanarScene s = test::make_planar_scene(64, 32);
    const SceneFlowField good = test::sample_matches(s.truth, 0.2, 0.0, 17);
    const interpolation::RobustInterpolator ri{interpolation::InterpolationOptions{}};
    const SparseLidar none;
    ri.run(good, none, s.image);  // the baseline call succeeds

    cv::Mat small;
    cv::resize(s.image, small, cv::Size(32, 32));
    expect_error([&] { ri.run(good, none, small); }, ErrorCode::SizeMismatch);
    expect_error([&] { ri.run(good, none, cv::Mat()); }, ErrorCode::InvalidArgument);
    cv::Mat img16;
    s.image.convertTo(img16, CV_16UC3);
    expect_error([&] { ri.run(good, none, img16); }, ErrorCode::InvalidArgument);

    SceneFlowField empty = SceneFlowField::zeros(64, 32);
    expect_error([&] { ri.run(empty, none, s.image); }, ErrorCode::InvalidArgument);
    auto copy = [&] {
        return SceneFlowField{good.u.clone(), good.v.clone(), good.d0.clone(), good.d1.clone(),
                              good.valid.clone(), good.confidence.clone()};
    };
    cv::Point at(-1, -1);
    for (int y = 0; y < 32 && at.x < 0; ++y)
        for (int x = 0; x < 64 && at.x < 0; ++x)
            if (good.valid(y, x)) at = cv::Point(x, y);
    SceneFlowField bad = copy();
    bad.u(at) = std::nanf("");
    expect_error([&] { ri.run(bad, none, s.image); }, ErrorCode::InvalidArgument);
    bad = copy();
    bad.d1(at) = std::numeric_limits<float>::infinity();
    expect_error([&] { ri.run(bad, none, s.image); }, ErrorCode::InvalidArgument);
    bad = copy();
    bad.d0(at) = -2.0f;
    expect_error([&] { ri.run(bad, none, s.image); }, ErrorCode::InvalidArgument);
    bad = copy();
    bad.v = cv::Mat1f(16, 64, 0.0f);
    expect_error([&] { ri.run(bad, none, s.image); }, ErrorCode::SizeMismatch);
    bad = copy();
    bad.u.release();
    expect_error([&] { ri.run(bad, none, s.image); }, ErrorCode::InvalidArgument);

    SparseLidar lidar;
    lidar.width = 64, lidar.height = 32;
    lidar.points.push_back({64, 5, 10.0f});
    expect_error([&] { ri.run(good, lidar, s.image); }, ErrorCode::InvalidArgument);
    lidar.points = {{3, 5, std::nanf("")}};
    expect_error([&] { ri.run(good, lidar, s.image); }, ErrorCode::InvalidArgument);
    lidar.points = {{3, 5, -1.0f}};
    expect_error([&] { ri.run(good, lidar, s.image); }, ErrorCode::InvalidArgument);
    lidar.points = {{3, 5, 10.0f}};
    lidar.width = 65;
    expect_error([&] { ri.run(good, lidar, s.image); }, ErrorCode::SizeMismatch);

    auto with = [](auto edit) {
        interpolation::InterpolationOptions o;
        edit(o);
        return [o] { interpolation::RobustInterpolator{o}; };
    };
    using O = interpolation::InterpolationOptions;
    expect_error(with([](O &o) { o.num_neighbors = 0; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.distance_sigma = std::nanf(""); }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.edge_gain = -1; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.num_threads = 0; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.superpixels.region_size = 2; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.lidar_disparity_tolerance = 0; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.edges.contrast_gain = 0; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.lidar_points_per_superpixel = std::nanf(""); }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.lidar_points_per_superpixel = -1; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.min_superpixel_size = 3; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.lidar_residual_radius = std::nanf(""); }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.lidar_residual_radius = -1; }), ErrorCode::InvalidArgument);
    expect_error(with([](O &o) { o.lidar_residual_radius = 65; }), ErrorCode::InvalidArgument);
}

// The optional SED model: a missing file is an I/O error, a file that is not a model a
// format error; both when the interpolator is built, not on the first frame.
void sed_model_errors(void **) {
    const auto dir = test::scratch_dir("interpolation_sed");
    interpolation::InterpolationOptions o;
    o.edges.method = interpolation::EdgeMethod::StructuredForest;
    o.edges.sed_model_path = (dir / "missing.yml.gz").string();
    expect_error([&] { interpolation::RobustInterpolator{o}; }, ErrorCode::Io);
    o.edges.sed_model_path = "";
    expect_error([&] { interpolation::RobustInterpolator{o}; }, ErrorCode::InvalidArgument);

    const auto garbage = dir / "garbage.yml";
    std::FILE *f = std::fopen(garbage.string().c_str(), "w");
    assert_non_null(f);
    std::fputs("this is { not : a model ]\n", f);
    std::fclose(f);
    o.edges.sed_model_path = garbage.string();
    expect_error([&] { interpolation::RobustInterpolator{o}; }, ErrorCode::Format);

    const auto yaml = dir / "other.yml";
    f = std::fopen(yaml.string().c_str(), "w");
    assert_non_null(f);
    std::fputs("%YAML:1.0\n---\nthrs: [ 1, 2 ]\n", f);
    std::fclose(f);
    o.edges.sed_model_path = yaml.string();
    expect_error([&] { interpolation::RobustInterpolator{o}; }, ErrorCode::Format);

    // An XML model cut after an attribute's '=' (OpenCV's XML parser would crash on it).
    const auto cut = dir / "cut.xml";
    std::ofstream(cut) << "<?xml version=\"1.0\"?>\n<opencv_storage>\n<options type_id= \n";
    o.edges.sed_model_path = cut.string();
    expect_error([&] { interpolation::RobustInterpolator{o}; }, ErrorCode::Format);

    // Built-in edge maps: soft, in [0, 1], high on the scene's region boundaries.
    const test::PlanarScene s = test::make_planar_scene();
    for (auto method : {interpolation::EdgeMethod::Gradient, interpolation::EdgeMethod::MultiScaleGradient}) {
        interpolation::EdgeMapOptions eo;
        eo.method = method;
        const cv::Mat1f e = interpolation::compute_edge_map(s.image, eo);
        double lo, hi;
        cv::minMaxLoc(e, &lo, &hi);
        assert_true(lo >= 0.0 && hi <= 1.0);
        assert_true(e(60, 20) > 0.5f);   // background / ground boundary
        assert_true(e(30, 20) < 0.3f);   // inside the background
    }
    interpolation::EdgeMapOptions sed_without_model;
    sed_without_model.method = interpolation::EdgeMethod::StructuredForest;
    expect_error([&] { interpolation::compute_edge_map(s.image, sed_without_model); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(reproduces_piecewise_planar_scene),
        cmocka_unit_test(lidar_anchors_are_honoured),
        cmocka_unit_test(lidar_fixes_coherently_wrong_superpixel),
        cmocka_unit_test(works_with_very_few_matches),
        cmocka_unit_test(handles_collinear_and_tiny_inputs),
        cmocka_unit_test(works_with_dense_matches),
        cmocka_unit_test(deterministic_for_any_thread_count),
        cmocka_unit_test(rejects_invalid_input),
        cmocka_unit_test(sed_model_errors),
        cmocka_unit_test(superpixels_shrink_with_dense_lidar),
        cmocka_unit_test(image_work_computed_ahead),
        cmocka_unit_test(lidar_residuals_follow_a_curved_surface),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
