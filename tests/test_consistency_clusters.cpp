// SPDX-License-Identifier: MIT
// Clustering, 3x3 sparsification and the whole stage 2-3 chain on hand-built fields; the rule
// "LiDAR pixels survive every filter" on a field where every match is wrong.
#include <cmath>
#include <limits>
#include <vector>

#include "consistency/consistency.hpp"
#include "synth_fields.hpp"
#include "consistency_fixtures.hpp"  // last: brings cmocka

using namespace lidarflow;
using namespace lidarflow::consistency;
using lidarflow::test::constant_field;
using lidarflow::test::lidar_at;
using lidarflow::test::set_match;

namespace {

constexpr int W = 30, H = 30;

LidarReference no_lidar(int w = W, int h = H) { return LidarReference::build(SparseLidar{}, w, h, 15); }

void fill_block(SceneFlowField &f, int x0, int y0, int bw, int bh, float u, float v, float d0, float d1) {
    for (int y = y0; y < y0 + bh; ++y)
        for (int x = x0; x < x0 + bw; ++x) set_match(f, x, y, u, v, d0, d1);
}

ConsistencyOptions cluster_opt(int min_size) {
    ConsistencyOptions opt;
    opt.cluster_min_size = min_size;
    opt.cluster_max_flow_step = 1.0f;
    opt.cluster_max_disp_step = 1.0f;
    return opt;
}

void small_clusters_go_big_ones_stay(void **) {
    SceneFlowField f = SceneFlowField::zeros(W, H);
    fill_block(f, 0, 0, 12, 12, 2, 1, 20, 19);     // 144 matches
    fill_block(f, 20, 20, 3, 3, -4, 0, 8, 8);      // 9 matches, isolated
    fill_block(f, 12, 0, 3, 3, 9, 1, 20, 19);      // 9 matches touching the big block, but u jumps by 7
    // A smooth ramp is one cluster: neighbours differ by 0.5 only.
    for (int x = 0; x < 30; ++x) set_match(f, x, 15, 0.5f * x, 0, 10, 10);
    const ClusterResult r = remove_small_clusters(f, no_lidar(), cv::Mat1b(), cluster_opt(20));
    assert_int_equal(cv::countNonZero(r.field.valid(cv::Rect(0, 0, 12, 12))), 144);
    assert_int_equal(cv::countNonZero(r.field.valid(cv::Rect(20, 20, 3, 3))), 0);
    assert_int_equal(cv::countNonZero(r.field.valid(cv::Rect(12, 0, 3, 3))), 0);
    assert_int_equal(cv::countNonZero(r.field.valid.row(15)), 30);
    assert_int_equal(r.clusters, 4);
    assert_int_equal(r.removed_clusters, 2);
    assert_int_equal(static_cast<int>(r.removed_matches), 18);
    // A threshold of 9 keeps the 9-match clusters.
    assert_int_equal(cv::countNonZero(remove_small_clusters(f, no_lidar(), cv::Mat1b(), cluster_opt(9)).field.valid),
                     cv::countNonZero(f.valid));
}

void each_component_can_split_a_cluster(void **) {
    // Two 5x10 halves that differ in one component only: split when that step exceeds 1 px.
    const float steps[4][4] = {{1.5f, 0, 0, 0}, {0, 1.5f, 0, 0}, {0, 0, 1.5f, 0}, {0, 0, 0, 1.5f}};
    for (const auto &s : steps) {
        SceneFlowField f = SceneFlowField::zeros(10, 10);
        fill_block(f, 0, 0, 5, 10, 1, 1, 10, 10);
        fill_block(f, 5, 0, 5, 10, 1 + s[0], 1 + s[1], 10 + s[2], 10 + s[3]);
        const ClusterResult r = remove_small_clusters(f, no_lidar(10, 10), cv::Mat1b(), cluster_opt(60));
        assert_int_equal(r.clusters, 2);
        assert_int_equal(cv::countNonZero(r.field.valid), 0);
    }
}

void neighbourhood_and_grid_step(void **) {
    // A diagonal chain of 10 matches: one cluster with 8 neighbours, 10 singletons with 4.
    SceneFlowField f = SceneFlowField::zeros(W, H);
    for (int i = 0; i < 10; ++i) set_match(f, i, i, 1, 1, 5, 5);
    ConsistencyOptions opt = cluster_opt(10);
    assert_int_equal(cv::countNonZero(remove_small_clusters(f, no_lidar(), cv::Mat1b(), opt).field.valid), 10);
    opt.cluster_8_neighbours = false;
    assert_int_equal(cv::countNonZero(remove_small_clusters(f, no_lidar(), cv::Mat1b(), opt).field.valid), 0);

    // Matches on a step-3 grid: 4x4 = 16 seeds are one cluster only when neighbours are 3 px apart.
    SceneFlowField g = SceneFlowField::zeros(W, H);
    for (int y = 0; y < 12; y += 3)
        for (int x = 0; x < 12; x += 3) set_match(g, x, y, 1, 1, 5, 5);
    ConsistencyOptions grid = cluster_opt(10);
    assert_int_equal(cv::countNonZero(remove_small_clusters(g, no_lidar(), cv::Mat1b(), grid).field.valid), 0);
    grid.grid_step = 3;
    assert_int_equal(cv::countNonZero(remove_small_clusters(g, no_lidar(), cv::Mat1b(), grid).field.valid), 16);
}

void lidar_references_keep_their_cluster(void **) {
    SceneFlowField f = SceneFlowField::zeros(W, H);
    fill_block(f, 2, 2, 3, 3, 1, 1, 10, 10);    // holds the LiDAR pixel (3, 3)
    fill_block(f, 20, 2, 3, 3, 1, 1, 10, 10);   // holds (21, 3), flagged unreliable after 2b
    fill_block(f, 2, 20, 3, 3, 1, 1, 10, 10);   // no LiDAR
    const LidarReference lidar = LidarReference::build(lidar_at(W, H, {{3, 3, 10.0f}, {21, 3, 10.0f}}), W, H, 3);
    cv::Mat1b unreliable = cv::Mat1b::zeros(H, W);
    unreliable(3, 21) = 1;
    ConsistencyOptions opt = cluster_opt(20);
    ClusterResult r = remove_small_clusters(f, lidar, unreliable, opt);
    assert_int_equal(cv::countNonZero(r.field.valid(cv::Rect(2, 2, 3, 3))), 9);   // LiDAR region kept
    assert_int_equal(cv::countNonZero(r.field.valid(cv::Rect(20, 2, 3, 3))), 1);  // only the LiDAR pixel
    assert_int_equal(r.field.valid(3, 21), 1);
    assert_int_equal(cv::countNonZero(r.field.valid(cv::Rect(2, 20, 3, 3))), 0);
    // Without the reference rule the first region goes too, except its LiDAR pixel.
    opt.keep_lidar_clusters = false;
    r = remove_small_clusters(f, lidar, unreliable, opt);
    assert_int_equal(cv::countNonZero(r.field.valid(cv::Rect(2, 2, 3, 3))), 1);
    assert_int_equal(r.field.valid(3, 3), 1);
}

// Clusters are found in strips of rows, one per thread: regions that wind across the strips'
// borders (a random field, values on a coarse random grid) come out the same for any count.
void clusters_do_not_depend_on_threads(void **) {
    const int w = 64, h = 97;
    SceneFlowField f = SceneFlowField::zeros(w, h);
    cv::RNG rng(7);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (rng.uniform(0, 10) == 0) continue;  // holes
            const float c = static_cast<float>(((x / 3) * 7 + (y / 2) * 13) % 5);
            set_match(f, x, y, c + rng.uniform(0.0f, 0.5f), c, 10 + c, 10 + c);
        }
    const LidarReference lidar = LidarReference::build(lidar_at(w, h, {{5, 50, 11.0f}, {40, 24, 12.0f}}), w, h, 3);
    for (int step : {1, 2})
        for (bool eight : {true, false}) {
            ConsistencyOptions opt = cluster_opt(12);
            opt.grid_step = step;
            opt.cluster_8_neighbours = eight;
            opt.threads = 1;
            const ClusterResult one = remove_small_clusters(f, lidar, cv::Mat1b(), opt);
            assert_true(one.removed_clusters > 0 && one.removed_clusters < one.clusters);
            for (int threads : {2, 3, 5, 16}) {
                opt.threads = threads;
                const ClusterResult many = remove_small_clusters(f, lidar, cv::Mat1b(), opt);
                assert_int_equal(many.clusters, one.clusters);
                assert_int_equal(many.removed_clusters, one.removed_clusters);
                assert_int_equal(many.removed_matches, one.removed_matches);
                assert_int_equal(cv::countNonZero(many.field.valid != one.field.valid), 0);
            }
        }
}

// The clusters are the field's connected components: a breadth-first search over the same
// neighbours and steps gives the same kept matches and counts, on noisy fields with holes.
void clusters_are_the_components_of_the_field(void **) {
    const int w = 151, h = 118;
    for (int seed = 1; seed <= 3; ++seed) {
        SceneFlowField f = SceneFlowField::zeros(w, h);
        cv::RNG rng(static_cast<uint64_t>(seed));
        // Rectangles of random size and level (levels 2 apart: only equal ones join), noise
        // that sometimes breaks a link, holes.
        cv::Mat1f level(h, w, 0.0f);
        for (int k = 0; k < 300; ++k) {
            const cv::Rect r(rng.uniform(0, w), rng.uniform(0, h), 1 + rng.uniform(0, 30), 1 + rng.uniform(0, 20));
            level(r & cv::Rect(0, 0, w, h)).setTo(2.0f * rng.uniform(0, 12));
        }
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                if (rng.uniform(0, 12) == 0) continue;
                const float c = level(y, x);
                set_match(f, x, y, c + rng.uniform(-0.5f, 0.5f), c, 10 + c, 10 + c + rng.uniform(0.0f, 1.05f));
            }
        for (int step : {1, 2, 3})
            for (bool eight : {true, false}) {
                ConsistencyOptions opt = cluster_opt(25);
                opt.grid_step = step;
                opt.cluster_8_neighbours = eight;
                // Reference: breadth-first search from each unvisited match.
                cv::Mat1i comp(h, w, -1);
                std::vector<int> sizes;
                const int dx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, dy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
                for (int y = 0; y < h; ++y)
                    for (int x = 0; x < w; ++x) {
                        if (!f.valid(y, x) || comp(y, x) >= 0) continue;
                        const int id = static_cast<int>(sizes.size());
                        sizes.push_back(0);
                        std::vector<cv::Point> queue{{x, y}};
                        comp(y, x) = id;
                        for (size_t q = 0; q < queue.size(); ++q) {
                            const cv::Point p = queue[q];
                            ++sizes.back();
                            for (int k = 0; k < (eight ? 8 : 4); ++k) {
                                const int nx = p.x + dx[k] * step, ny = p.y + dy[k] * step;
                                if (nx < 0 || ny < 0 || nx >= w || ny >= h || !f.valid(ny, nx) || comp(ny, nx) >= 0)
                                    continue;
                                if (std::fabs(f.u(p.y, p.x) - f.u(ny, nx)) > opt.cluster_max_flow_step ||
                                    std::fabs(f.v(p.y, p.x) - f.v(ny, nx)) > opt.cluster_max_flow_step ||
                                    std::fabs(f.d0(p.y, p.x) - f.d0(ny, nx)) > opt.cluster_max_disp_step ||
                                    std::fabs(f.d1(p.y, p.x) - f.d1(ny, nx)) > opt.cluster_max_disp_step)
                                    continue;
                                comp(ny, nx) = id;
                                queue.emplace_back(nx, ny);
                            }
                        }
                    }
                int small = 0;
                for (int n : sizes) small += n < opt.cluster_min_size;
                assert_true(small > 0 && small < static_cast<int>(sizes.size()));
                for (int threads : {1, 2, 4}) {
                    opt.threads = threads;
                    const ClusterResult r = remove_small_clusters(f, no_lidar(w, h), cv::Mat1b(), opt);
                    assert_int_equal(r.clusters, static_cast<int>(sizes.size()));
                    assert_int_equal(r.removed_clusters, small);
                    for (int y = 0; y < h; ++y)
                        for (int x = 0; x < w; ++x) {
                            const bool kept = f.valid(y, x) && sizes[static_cast<size_t>(comp(y, x))] >= 25;
                            if ((r.field.valid(y, x) != 0) != kept)
                                fail_msg("seed %d, step %d, %s neighbours, %d threads: (%d, %d) %s", seed, step,
                                         eight ? "8" : "4", threads, x, y, kept ? "removed" : "kept");
                        }
                }
            }
    }
}

void sparsify_keeps_most_consistent_per_block(void **) {
    // 10 x 7: blocks of 3x3, cut to 1 column / 1 row at the right / bottom border.
    const int w = 10, h = 7;
    SceneFlowField f = constant_field(w, h, 1, 1, 10, 10);
    cv::Mat1f err(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) err(y, x) = static_cast<float>((x * 7 + y * 13) % 17) + 0.5f;
    f.valid(4, 4) = 0;  // the block (3..5, 3..5) loses a pixel
    err(1, 7) = std::numeric_limits<float>::infinity();
    // A tie in block (0..2, 0..2): the higher confidence wins.
    err(0, 0) = 0.1f;
    err(2, 1) = 0.1f;
    f.confidence(2, 1) = 2.0f;
    // An empty block stays empty.
    for (int y = 6; y < 7; ++y)
        for (int x = 9; x < 10; ++x) f.valid(y, x) = 0;
    const LidarReference lidar = LidarReference::build(lidar_at(w, h, {{4, 1, 10.0f}}), w, h, 3);
    err(1, 4) = 100.0f;  // the LiDAR pixel is kept even with the worst error
    ConsistencyOptions own;
    own.sparsify_support = 1;  // rank by the match's own error
    const SceneFlowField s = sparsify(f, err, lidar, own);

    for (int by = 0; by < h; by += 3)
        for (int bx = 0; bx < w; bx += 3) {
            int best_x = -1, best_y = -1, kept = 0;
            float best = 0, best_c = 0;
            for (int y = by; y < std::min(by + 3, h); ++y)
                for (int x = bx; x < std::min(bx + 3, w); ++x) {
                    if (s.valid(y, x) && !lidar.is_lidar(y, x)) ++kept;
                    if (!f.valid(y, x) || lidar.is_lidar(y, x)) continue;
                    const float c = f.confidence(y, x);
                    if (best_x < 0 || err(y, x) < best || (err(y, x) == best && c > best_c)) {
                        best_x = x, best_y = y, best = err(y, x), best_c = c;
                    }
                }
            assert_int_equal(kept, best_x < 0 ? 0 : 1);
            if (best_x >= 0) assert_int_equal(s.valid(best_y, best_x), 1);
        }
    assert_int_equal(s.valid(2, 1), 1);  // tie broken by confidence
    assert_int_equal(s.valid(0, 0), 0);
    assert_int_equal(s.valid(1, 4), 1);  // LiDAR, in addition to its block's best
    assert_int_equal(cv::countNonZero(s.valid), 4 * 3 - 1 + 1);  // 12 blocks, one empty, + LiDAR
    // Values are carried over.
    assert_true(s.d0(2, 1) == 10.0f && s.u(2, 1) == 1.0f);
    // NaN in the error map is rejected.
    err(5, 5) = std::nanf("");
    int code = 0;
    try {
        sparsify(f, err, lidar, own);
    } catch (const Error &e) {
        code = static_cast<int>(e.code());
    }
    assert_int_equal(code, static_cast<int>(ErrorCode::InvalidArgument));
}

void sparsify_prefers_matches_inside_consistent_regions(void **) {
    // One 3x3 block (x 3..5, y 3..5) of a field whose survivors fill x >= 4 only. The block's
    // own best error sits at (3, 4), on the ragged edge next to removed matches; (5, 4) is a
    // little worse on its own but surrounded by good survivors.
    const int w = 9, h = 9;
    SceneFlowField f = constant_field(w, h, 1, 1, 10, 10);
    cv::Mat1f err(h, w, 0.5f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < 3; ++x) f.valid(y, x) = 0;
    err(4, 3) = 0.2f;
    err(4, 5) = 0.3f;
    err(3, 3) = err(5, 3) = 1.0f;
    for (int x = 4; x <= 6; ++x) err(2, x) = err(6, x) = 1.0f;  // (5, 3) and (5, 5) see these
    const LidarReference none = LidarReference::build(SparseLidar{}, w, h, 1);
    ConsistencyOptions opt;  // default: 3x3 support
    const SceneFlowField s = sparsify(f, err, none, opt);
    assert_int_equal(s.valid(4, 5), 1);
    assert_int_equal(s.valid(4, 3), 0);
    opt.sparsify_support = 1;
    const SceneFlowField own = sparsify(f, err, none, opt);
    assert_int_equal(own.valid(4, 3), 1);
    assert_int_equal(own.valid(4, 5), 0);
}

// Every match is wrong (d0 far from SGM, round trips inconsistent, no two neighbours alike),
// except the motion of two LiDAR pixels: the chain must remove every non-LiDAR match, and the
// valid LiDAR pixels survive every filter with the LiDAR disparity as d0 - all of them when
// keep_unreliable_lidar is set, else all in 2a and only the two with consistent motion in 2b.
void lidar_pixels_survive_every_filter(void **) {
    const int w = 60, h = 45;
    SceneFlowField f = SceneFlowField::zeros(w, h), b = SceneFlowField::zeros(w, h);
    cv::RNG rng(3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            // Forward disparities in [40, 90], backward in [0, 30]: no round trip can agree.
            set_match(f, x, y, rng.uniform(-20.f, 20.f), rng.uniform(-20.f, 20.f), rng.uniform(40.f, 90.f),
                      rng.uniform(40.f, 90.f));
            set_match(b, x, y, rng.uniform(-20.f, 20.f), rng.uniform(-20.f, 20.f), rng.uniform(0.f, 30.f),
                      rng.uniform(0.f, 30.f));
            f.confidence(y, x) = rng.uniform(0.f, 1.f);
        }
    const DisparityMap sgm(h, w, 5.0f);
    // Eight LiDAR points, one of them (50, 40) on an invalid match: nothing to keep there.
    const SparseLidar lidar = lidar_at(w, h, {{5, 5, 7.0f}, {6, 5, 7.5f}, {30, 10, 12.0f}, {59, 0, 3.0f},
                                              {0, 44, 20.0f}, {20, 30, 9.0f}, {40, 20, 1.0f}, {50, 40, 2.0f}});
    f.valid(40, 50) = 0;
    // (30, 10) and (20, 30) move by (3, 2) and B comes back exactly, with d0_b = d1.
    for (const cv::Point p : {cv::Point(30, 10), cv::Point(20, 30)}) {
        f.u(p.y, p.x) = 3.0f;
        f.v(p.y, p.x) = 2.0f;
        set_match(b, p.x + 3, p.y + 2, -3.0f, -2.0f, f.d1(p.y, p.x), 1.0f);
    }
    auto reliable = [](const LidarPoint &p) { return (p.x == 30 && p.y == 10) || (p.x == 20 && p.y == 30); };

    for (const bool keep_unreliable : {true, false}) {
        ConsistencyOptions opt;
        opt.support_window = 1;  // windows would exempt their neighbours from 2a: keep the test sharp
        opt.cluster_min_size = 5;
        opt.keep_unreliable_lidar = keep_unreliable;
        const ConsistencyResult r = run_consistency(f, b, sgm, lidar, opt);
        const int after_fb = keep_unreliable ? 7 : 2;
        assert_int_equal(cv::countNonZero(r.after_sgm.valid), 7);
        assert_int_equal(cv::countNonZero(r.after_fb.valid), after_fb);
        assert_int_equal(cv::countNonZero(r.sparse.valid), after_fb);
        for (const SceneFlowField *stage : {&r.after_sgm, &r.after_fb, &r.sparse})
            for (const LidarPoint &p : lidar.points) {
                const bool expected = p.x != 50 && (stage == &r.after_sgm || keep_unreliable || reliable(p));
                assert_int_equal(stage->valid(p.y, p.x), expected ? 1 : 0);
                if (!expected) continue;
                assert_true(stage->d0(p.y, p.x) == p.disparity);
                assert_true(stage->u(p.y, p.x) == f.u(p.y, p.x) && stage->d1(p.y, p.x) == f.d1(p.y, p.x));
            }
        assert_int_equal(r.counts.lidar_pixels, 8);
        assert_int_equal(static_cast<int>(r.counts.input), w * h - 1);
        assert_int_equal(r.counts.lidar_motion_unreliable, 5);
        assert_int_equal(cv::countNonZero(r.lidar_pixels), 8);
        assert_int_equal(r.lidar_motion_unreliable(10, 30) + r.lidar_motion_unreliable(30, 20), 0);
    }

    // The image-only mode on the same field removes everything.
    const ConsistencyResult io = run_consistency(f, b, sgm, SparseLidar{}, ConsistencyOptions{});
    assert_int_equal(cv::countNonZero(io.after_sgm.valid), 0);
    assert_int_equal(cv::countNonZero(io.sparse.valid), 0);
}

void chain_on_consistent_field(void **) {
    // A clean, consistent field: 2a, 2b and clustering keep all verifiable matches and
    // sparsification keeps one per 3x3 block; the intermediate fields are nested.
    const int w = 33, h = 24;
    const SceneFlowField f = constant_field(w, h, 2, 0, 10, 9);
    const SceneFlowField b = lidarflow::test::matching_backward(w, h, 2, 0, 10, 9);
    const DisparityMap sgm(h, w, 10.0f);
    ConsistencyOptions opt;
    opt.cluster_min_size = 10;
    const ConsistencyResult r = run_consistency(f, b, sgm, lidar_at(w, h, {{16, 12, 10.0f}}), opt);
    assert_int_equal(static_cast<int>(r.counts.after_sgm_clusters), w * h);
    // q leaves the image for x >= w - 2; with the default search radius 1, x = w - 2 still
    // finds B at w - 1 and comes back 1 px off (within 2 px).
    assert_int_equal(static_cast<int>(r.counts.after_fb_clusters), (w - 1) * h);
    assert_int_equal(static_cast<int>(r.counts.sparse), 11 * 8 + 1);
    assert_int_equal(r.counts.lidar_motion_unreliable, 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            assert_true(r.after_fb.valid(y, x) <= r.after_sgm.valid(y, x));
            assert_true(r.sparse.valid(y, x) <= r.after_fb.valid(y, x));
        }
    assert_true(r.seconds.total >= 0.0 && r.seconds.sgm == 0.0);
}

// Without the clustering after 2a (after_sgm_field false) stage 2b, its clustering and stage 3
// give the same fields bit for bit, on random patchworks of small and large regions whose
// round trips fail at random, with LiDAR pixels inside them, for every LiDAR rule and grid.
void clustering_after_2a_changes_nothing_later(void **) {
    const int w = 48, h = 36;
    int removed_by_2a = 0, removed_by_2b = 0;
    for (int seed = 1; seed <= 12; ++seed) {
        cv::RNG rng(static_cast<uint64_t>(seed));
        SceneFlowField f = SceneFlowField::zeros(w, h), b = SceneFlowField::zeros(w, h);
        for (int k = 0; k < 60; ++k) {
            const int bw = rng.uniform(1, 12), bh = rng.uniform(1, 10);
            const int x0 = rng.uniform(0, w - bw + 1), y0 = rng.uniform(0, h - bh + 1);
            // Values on a coarse lattice: touching regions join or stay apart at random.
            const float u = static_cast<float>(rng.uniform(-3, 4)), v = static_cast<float>(rng.uniform(-2, 3));
            const float d0 = static_cast<float>(rng.uniform(10, 14)), d1 = d0 - static_cast<float>(rng.uniform(0, 2));
            fill_block(f, x0, y0, bw, bh, u, v, d0, d1);
        }
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                if (!f.valid(y, x)) continue;
                f.confidence(y, x) = rng.uniform(0.f, 1.f);
                const int qx = x + static_cast<int>(f.u(y, x)), qy = y + static_cast<int>(f.v(y, x));
                if (qx < 0 || qy < 0 || qx >= w || qy >= h || rng.uniform(0.f, 1.f) < 0.3f) continue;
                set_match(b, qx, qy, -f.u(y, x), -f.v(y, x), f.d1(y, x), f.d0(y, x));
            }
        std::vector<LidarPoint> points;
        for (int k = 0; k < 10; ++k) {
            const int x = rng.uniform(0, w), y = rng.uniform(0, h);
            if (f.valid(y, x)) points.push_back({x, y, f.d0(y, x)});
        }
        const SparseLidar lidar = lidar_at(w, h, {});  // image-only
        SparseLidar with_points = lidar;
        with_points.points = points;
        const DisparityMap sgm = f.d0.clone();
        for (const SparseLidar *l : {&lidar, static_cast<const SparseLidar *>(&with_points)})
            for (const bool keep_clusters : {true, false})
                for (const bool keep_unreliable : {true, false})
                    for (const int radius : {0, 1}) {
                        ConsistencyOptions opt;
                        opt.support_window = 1;
                        opt.cluster_min_size = 12;
                        opt.keep_lidar_clusters = keep_clusters;
                        opt.keep_unreliable_lidar = keep_unreliable;
                        opt.fb_search_radius = radius;
                        opt.grid_step = 1 + seed % 2;
                        const ConsistencyResult with = run_consistency(f, b, sgm, *l, opt);
                        opt.after_sgm_field = false;
                        const ConsistencyResult without = run_consistency(f, b, sgm, *l, opt);
                        assert_true(without.after_sgm.u.empty());
                        assert_true(test::same_field(with.after_fb, without.after_fb));
                        assert_true(test::same_field(with.sparse, without.sparse));
                        assert_true(cv::norm(with.lidar_motion_unreliable, without.lidar_motion_unreliable,
                                             cv::NORM_INF) == 0);
                        removed_by_2a += with.counts.after_sgm_clusters < with.counts.after_sgm_check;
                        removed_by_2b += with.counts.after_fb_check < with.counts.after_sgm_clusters;
                    }
    }
    // The fields had small regions for the first clustering and round trips for 2b to fail.
    assert_true(removed_by_2a > 100 && removed_by_2b > 100);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(small_clusters_go_big_ones_stay),
        cmocka_unit_test(each_component_can_split_a_cluster),
        cmocka_unit_test(neighbourhood_and_grid_step),
        cmocka_unit_test(lidar_references_keep_their_cluster),
        cmocka_unit_test(clusters_do_not_depend_on_threads),
        cmocka_unit_test(clusters_are_the_components_of_the_field),
        cmocka_unit_test(sparsify_keeps_most_consistent_per_block),
        cmocka_unit_test(sparsify_prefers_matches_inside_consistent_regions),
        cmocka_unit_test(lidar_pixels_survive_every_filter),
        cmocka_unit_test(chain_on_consistent_field),
        cmocka_unit_test(clustering_after_2a_changes_nothing_later),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
