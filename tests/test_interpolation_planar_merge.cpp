// SPDX-License-Identifier: MIT
// merge_planar_superpixels on a textured image whose LiDAR (every second pixel below row 30)
// sees two planes with a depth step between them, and nothing above:
//  - superpixels merge on each plane and above the scan, never across the step, never beyond
//    max_area, and every merged region's points lie within the tolerance of one plane;
//  - the result is a valid segmentation (labels 0 .. count-1, each 4-connected, anchors inside,
//    symmetric adjacency, `parts` counting the merged superpixels), the same on every run; each
//    rule acts alone; off (tolerance 0, not unseen) it is the input;
//  - noisy points (+-1 px) do not merge at a 0.3 px tolerance; bad arguments are refused.
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "interpolation/planar_merge.hpp"
#include "interpolation/superpixels.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::interpolation;

namespace {

constexpr int kW = 160, kH = 80, kStep = 80, kScanTop = 30;

struct Scene {
    cv::Mat image;
    std::vector<cv::Point> pos;
    std::vector<float> disparity;
    std::vector<int> plane;  // 0 left of the step, 1 right
};

Scene make_scene(double noise) {
    Scene s;
    s.image = cv::Mat(kH, kW, CV_8UC3);
    cv::randu(s.image, cv::Scalar::all(60), cv::Scalar::all(200));
    cv::GaussianBlur(s.image, s.image, cv::Size(3, 3), 0);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> jitter(static_cast<float>(-noise), static_cast<float>(noise));
    for (int y = kScanTop; y < kH; y += 2)
        for (int x = 0; x < kW; x += 2) {
            const bool left = x < kStep;
            s.pos.emplace_back(x, y);
            s.disparity.push_back((left ? 20.0f + 0.05f * x + 0.02f * y : 40.0f - 0.03f * x) + jitter(rng));
            s.plane.push_back(left ? 0 : 1);
        }
    return s;
}

Superpixels segment(const cv::Mat &image) {
    SuperpixelOptions o;
    o.region_size = 10;
    return compute_superpixels(image, o);
}

PlanarMergeOptions options(float tolerance) {
    PlanarMergeOptions o;
    o.tolerance = tolerance;
    o.unseen = true;
    o.max_area = 400;
    return o;
}

// Labels 0 .. count-1, each one 4-connected piece; anchors inside; adjacency symmetric.
void expect_valid(const Superpixels &sp) {
    double lo, hi;
    cv::minMaxLoc(sp.labels, &lo, &hi);
    assert_int_equal(static_cast<int>(lo), 0);
    assert_int_equal(static_cast<int>(hi), sp.count - 1);
    for (int l = 0; l < sp.count; ++l) {
        const cv::Mat1b mask = sp.labels == l;
        cv::Mat1i cc;
        assert_int_equal(cv::connectedComponents(mask, cc, 4), 2);  // background + one piece
        assert_int_equal(cv::countNonZero(mask), sp.pixel_count[static_cast<size_t>(l)]);
        assert_int_equal(sp.labels(sp.anchor[static_cast<size_t>(l)]), l);
        for (int k = sp.adj_start[l]; k < sp.adj_start[l + 1]; ++k) {
            const int t = sp.adj[static_cast<size_t>(k)];
            const auto b = sp.adj.begin() + sp.adj_start[t], e = sp.adj.begin() + sp.adj_start[t + 1];
            assert_true(std::find(b, e, l) != e);
        }
    }
}

// Largest |d - plane| of the points, the plane fitted by least squares.
double plane_residual(const std::vector<cv::Point> &p, const std::vector<float> &d) {
    cv::Mat1d A(static_cast<int>(p.size()), 3), b(static_cast<int>(p.size()), 1), x;
    for (size_t i = 0; i < p.size(); ++i) {
        const int r = static_cast<int>(i);
        A(r, 0) = p[i].x, A(r, 1) = p[i].y, A(r, 2) = 1, b(r, 0) = d[i];
    }
    cv::solve(A, b, x, cv::DECOMP_SVD);
    double worst = 0;
    for (size_t i = 0; i < p.size(); ++i)
        worst = std::max(worst, std::fabs(x(0) * p[i].x + x(1) * p[i].y + x(2) - d[i]));
    return worst;
}

void merges_planes_and_the_unseen_part_only(void **) {
    const Scene s = make_scene(0.0);
    const Superpixels sp = segment(s.image);
    const Superpixels m = merge_planar_superpixels(sp, s.pos, s.disparity, options(0.3f));
    expect_valid(m);
    std::printf("%d superpixels -> %d\n", sp.count, m.count);
    assert_true(m.count < sp.count * 2 / 3);
    // Which old superpixels each new one is made of.
    std::map<int, std::set<int>> parts;
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) parts[m.labels(y, x)].insert(sp.labels(y, x));
    int merged_above = 0, merged_on_planes = 0;
    for (const auto &[label, olds] : parts) {
        if (olds.size() < 2) continue;
        assert_true(m.pixel_count[static_cast<size_t>(label)] <= 400);
        std::vector<cv::Point> p;
        std::vector<float> d;
        std::set<int> planes;
        for (size_t i = 0; i < s.pos.size(); ++i)
            if (m.labels(s.pos[i]) == label) {
                p.push_back(s.pos[i]);
                d.push_back(s.disparity[i]);
                planes.insert(s.plane[i]);
            }
        if (p.empty()) {
            ++merged_above;
            continue;
        }
        ++merged_on_planes;
        assert_int_equal(planes.size(), 1);  // never across the step
        assert_true(plane_residual(p, d) <= 0.3 + 1e-3);
    }
    assert_true(merged_above > 0);
    assert_true(merged_on_planes > 0);

    const Superpixels again = merge_planar_superpixels(sp, s.pos, s.disparity, options(0.3f));
    assert_int_equal(again.count, m.count);
    assert_int_equal(cv::countNonZero(again.labels != m.labels), 0);
}

// The merged superpixels' centroids, anchors, pixel counts and adjacency are those of their label
// map computed afresh (superpixels_from_labels), for each rule and tolerance.
void merged_statistics_equal_a_fresh_computation(void **) {
    for (const double noise : {0.0, 1.0}) {
        const Scene s = make_scene(noise);
        const Superpixels sp = segment(s.image);
        PlanarMergeOptions planes_only = options(0.3f);
        planes_only.unseen = false;
        for (const PlanarMergeOptions &o : {options(0.3f), options(0.0f), planes_only, options(2.0f)}) {
            const Superpixels m = merge_planar_superpixels(sp, s.pos, s.disparity, o);
            const Superpixels fresh = superpixels_from_labels(m.labels.clone(), m.count, 1);
            assert_int_equal(m.count, fresh.count);
            assert_true(m.pixel_count == fresh.pixel_count);
            assert_true(m.centroid == fresh.centroid);
            assert_true(m.anchor == fresh.anchor);
            assert_true(m.adj_start == fresh.adj_start);
            assert_true(m.adj == fresh.adj);
        }
    }
}

void off_and_noisy_points_keep_the_superpixels(void **) {
    const Scene s = make_scene(0.0);
    const Superpixels sp = segment(s.image);
    PlanarMergeOptions none = options(0.0f);
    none.unseen = false;
    const Superpixels off = merge_planar_superpixels(sp, s.pos, s.disparity, none);
    assert_int_equal(off.count, sp.count);
    assert_int_equal(cv::countNonZero(off.labels != sp.labels), 0);
    // Each rule alone: tolerance 0 merges only where no point is near, unseen off only planes.
    PlanarMergeOptions planes_only = options(0.3f);
    planes_only.unseen = false;
    for (const PlanarMergeOptions &one : {options(0.0f), planes_only}) {
        const Superpixels m = merge_planar_superpixels(sp, s.pos, s.disparity, one);
        std::map<int, std::set<int>> parts;
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x) parts[m.labels(y, x)].insert(sp.labels(y, x));
        std::set<int> with_points;
        for (const cv::Point &p : s.pos) with_points.insert(m.labels(p));
        int merged_with = 0, merged_without = 0;
        for (const auto &[label, olds] : parts)
            if (olds.size() > 1) ++(with_points.count(label) ? merged_with : merged_without);
        assert_true(one.unseen ? merged_with == 0 && merged_without > 0 : merged_with > 0 && merged_without == 0);
        for (int l = 0; l < m.count; ++l)
            assert_int_equal(m.parts[static_cast<size_t>(l)], static_cast<int>(parts[l].size()));
    }
    PlanarMergeOptions no_area = options(0.3f);
    no_area.max_area = 0;
    assert_int_equal(merge_planar_superpixels(sp, s.pos, s.disparity, no_area).count, sp.count);

    // +-1 px of noise: the planes' superpixels stay apart; only those above the scan merge.
    const Scene noisy = make_scene(1.0);
    const Superpixels m = merge_planar_superpixels(segment(noisy.image), noisy.pos, noisy.disparity, options(0.3f));
    std::set<int> with_points;
    for (const cv::Point &p : noisy.pos) with_points.insert(m.labels(p));
    std::map<int, std::set<int>> parts;
    const Superpixels base = segment(noisy.image);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) parts[m.labels(y, x)].insert(base.labels(y, x));
    for (int l : with_points) assert_int_equal(parts[l].size(), 1);
    assert_true(m.count < base.count);
}

void refuses_bad_arguments(void **) {
    const Scene s = make_scene(0.0);
    const Superpixels sp = segment(s.image);
    std::vector<float> short_d(s.disparity.begin(), s.disparity.end() - 1);
    test::expect_error([&] { merge_planar_superpixels(sp, s.pos, short_d, options(0.3f)); },
                       ErrorCode::InvalidArgument);
    test::expect_error([&] { merge_planar_superpixels(sp, s.pos, s.disparity, options(-1.0f)); },
                       ErrorCode::InvalidArgument);
    test::expect_error([&] { merge_planar_superpixels(sp, s.pos, s.disparity, options(NAN)); },
                       ErrorCode::InvalidArgument);
    PlanarMergeOptions two = options(0.3f);
    two.min_points = 2;
    test::expect_error([&] { merge_planar_superpixels(sp, s.pos, s.disparity, two); }, ErrorCode::InvalidArgument);
    // Points outside the image and non-finite disparities are ignored.
    std::vector<cv::Point> p = s.pos;
    std::vector<float> d = s.disparity;
    p.emplace_back(-5, 3), d.push_back(10.0f);
    p.emplace_back(kW, kH), d.push_back(10.0f);
    p.emplace_back(3, 3), d.push_back(INFINITY);
    const Superpixels a = merge_planar_superpixels(sp, p, d, options(0.3f));
    const Superpixels b = merge_planar_superpixels(sp, s.pos, s.disparity, options(0.3f));
    assert_int_equal(cv::countNonZero(a.labels != b.labels), 0);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(merges_planes_and_the_unseen_part_only),
        cmocka_unit_test(off_and_noisy_points_keep_the_superpixels),
        cmocka_unit_test(merged_statistics_equal_a_fresh_computation),
        cmocka_unit_test(refuses_bad_arguments),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
