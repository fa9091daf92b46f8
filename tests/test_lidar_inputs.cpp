// SPDX-License-Identifier: MIT
// Sparse LiDAR inputs (src/lidar): projection of points into the left image, the 5x5-window
// grid sampler, the de-warp of D1 into I_l^1 with occlusion handling, the paper protocol and
// the Velodyne protocol; hand-built cases plus the real KITTI frames when available.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/velodyne.hpp"
#include "lidar/grid_sampling.hpp"
#include "lidar/paper_protocol.hpp"
#include "lidar/projection.hpp"
#include "lidar/velodyne_protocol.hpp"
#include "lidar/visibility_filter.hpp"
// cmocka.h defines fail(), which breaks <ios>, and its 1.1.5 header lacks extern "C": include
// it last, wrapped (test_support.hpp's own include is then a no-op).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;
using test::throws_code;

namespace {


StereoCamera test_camera() {
    StereoCamera c;
    c.fx = c.fy = 500;
    c.cx = 40;
    c.cy = 30;
    c.baseline = 0.5;
    return c;
}

const LidarPoint *find_point(const SparseLidar &s, int x, int y) {
    for (const LidarPoint &p : s.points)
        if (p.x == x && p.y == y) return &p;
    return nullptr;
}

std::string kitti_or_skip() {
    const std::string root = test::kitti_dir();
    if (root.empty()) std::printf("KITTI frames not available (LIDARFLOW_KITTI_DIR): skipped\n");
    return root;
}

// --- projection -----------------------------------------------------------------------------

// Frame `id`'s Velodyne scan projected into its left image (of the size of `size`).
SparseLidar project_scan(const io::KittiLayout &L, const std::string &id, cv::Size size) {
    return lidar::project_to_left(io::read_velodyne_bin(L.velodyne(id)).points,
                                  io::read_calib_cam_to_cam(L.calib_cam_to_cam(id)),
                                  io::read_calib_velo_to_cam(L.calib_velo_to_cam(id)), size);
}

void test_projection_synthetic(void **) {
    const io::CamToCamCalib calib = io::calib_from_camera(test_camera());
    const cv::Size size(80, 60);
    const std::vector<cv::Point3d> pts = {
        {0.2, -0.1, 10.0},    // -> (50, 25), d = 25
        {0.2, -0.12, 20.0},   // -> (45, 27), d = 12.5
        {0.4, -0.2, 20.0},    // same pixel as the first, farther: loses
        {0.0, 0.0, -5.0},     // behind the camera
        {0.0, 0.0, 0.05},     // in front but below min_depth
        {5.0, 0.0, 10.0},     // right of the image (x = 290)
        {0.0, 0.0, 50.0},     // principal point (40, 30), d = 5
    };
    const SparseLidar s = lidar::project_to_left(pts, calib, size);
    assert_int_equal(s.width, 80);
    assert_int_equal(s.height, 60);
    assert_int_equal(s.points.size(), 3);
    const LidarPoint *a = find_point(s, 50, 25), *b = find_point(s, 45, 27), *c = find_point(s, 40, 30);
    assert_non_null(a);
    assert_non_null(b);
    assert_non_null(c);
    assert_true(std::fabs(a->disparity - 25.0f) < 1e-5f);
    assert_true(std::fabs(b->disparity - 12.5f) < 1e-5f);
    assert_true(std::fabs(c->disparity - 5.0f) < 1e-5f);

    // The Velodyne overload: identity transforms give the same result.
    std::vector<io::VelodynePoint> vp;
    for (const cv::Point3d &p : pts)
        vp.push_back({static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z), 0.0f});
    const SparseLidar s2 = lidar::project_to_left(vp, calib, cv::Matx44d::eye(), size);
    assert_int_equal(s2.points.size(), 3);
    for (std::size_t i = 0; i < 3; ++i) {
        assert_int_equal(s2.points[i].x, s.points[i].x);
        assert_int_equal(s2.points[i].y, s.points[i].y);
        assert_true(std::fabs(s2.points[i].disparity - s.points[i].disparity) < 1e-4f);
    }

    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::project_to_left(pts, calib, cv::Size(0, 10)); }));
    std::vector<cv::Point3d> bad = pts;
    bad.push_back({std::numeric_limits<double>::quiet_NaN(), 0, 1});
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::project_to_left(bad, calib, size); }));
    io::CamToCamCalib nocam = calib;
    nocam.camera = StereoCamera();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::project_to_left(pts, nocam, size); }));
    lidar::ProjectionOptions opt;
    opt.min_depth = 0;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::project_to_left(pts, calib, size, opt); }));
    cv::Matx44d nan_T = cv::Matx44d::eye();
    nan_T(0, 3) = std::numeric_limits<double>::infinity();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::project_to_left(vp, calib, nan_T, size); }));
}

// The real scan projected into I_l^0 agrees with KITTI's disp_occ_0 where both exist.
void test_projection_matches_ground_truth(void **) {
    const std::string root = kitti_or_skip();
    if (root.empty()) skip();
    const io::KittiLayout L{root};
    std::vector<double> pooled;
    for (const std::string &id : L.frame_ids()) {
        const DisparityMap gt = io::read_disparity_png(L.gt_disp0(id));
        const SparseLidar s = project_scan(L, id, gt.size());
        std::vector<double> err;
        for (const LidarPoint &p : s.points)
            if (disparity_valid(gt(p.y, p.x))) err.push_back(std::fabs(gt(p.y, p.x) - p.disparity));
        assert_true(err.size() > 5000);
        std::sort(err.begin(), err.end());
        const double median = err[err.size() / 2];
        std::printf("%s: %zu projected points, %zu on valid GT, median |d - d_gt| = %.4f px\n", id.c_str(),
                    s.points.size(), err.size(), median);
        assert_true(median < 0.1);
        pooled.insert(pooled.end(), err.begin(), err.end());
    }
    std::sort(pooled.begin(), pooled.end());
    std::printf("pooled median |d - d_gt| = %.4f px\n", pooled[pooled.size() / 2]);
    assert_true(pooled[pooled.size() / 2] < 0.1);
}

// --- grid sampler -------------------------------------------------------------------------

void test_grid_sampler(void **) {
    DisparityMap d(20, 20, kInvalidDisparity);
    // Window centred at (5, 5) (step 10, offset 5): candidates at distance 2, sqrt(2), 2.
    d(5, 7) = 1;
    d(6, 6) = 2;
    d(3, 5) = 3;
    // Window at (15, 5): a tie at distance 1 -> the first in row-major order, (15, 4).
    d(5, 16) = 4;
    d(4, 15) = 5;
    // Window at (5, 15): the only point lies outside the 5x5 window -> no sample.
    d(15, 8) = 6;
    // Window at (15, 15): its centre itself.
    d(15, 15) = 7;
    d(14, 15) = 8;
    const lidar::GridSpec g = lidar::grid_spec(10, false);
    assert_int_equal(g.offset.x, 5);
    const SparseLidar s = lidar::sample_grid(d, g);
    assert_int_equal(s.points.size(), 3);
    assert_true(find_point(s, 6, 6) && find_point(s, 6, 6)->disparity == 2);
    assert_true(find_point(s, 15, 4) && find_point(s, 15, 4)->disparity == 5);
    assert_true(find_point(s, 15, 15) && find_point(s, 15, 15)->disparity == 7);

    // A filter that refuses (6, 6) and the centre: the next-nearest candidates win.
    const SparseLidar f = lidar::sample_grid(d, g, [](int x, int y) { return !(x == 6 && y == 6) && !(x == 15 && y == 15); });
    assert_int_equal(f.points.size(), 3);
    // (5, 3) and (7, 5) are both 2 px from the centre: row-major order takes (5, 3).
    assert_non_null(find_point(f, 5, 3));
    assert_null(find_point(f, 7, 5));
    assert_non_null(find_point(f, 15, 14));

    // Half-shifted grid: centres at 0, 10 (offset (5 + 5) % 10).
    const lidar::GridSpec h = lidar::grid_spec(10, true);
    assert_int_equal(h.offset.x, 0);
    assert_int_equal(lidar::grid_spec(7, true).offset.x, 6);

    lidar::GridSpec bad = g;
    bad.step = 4;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_grid(d, bad); }));
    bad = g;
    bad.window = 4;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_grid(d, bad); }));
    bad = g;
    bad.offset.x = 10;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_grid(d, bad); }));
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_grid(DisparityMap(), g); }));

    // choose_step: the smallest cost, ties to the smaller step.
    assert_int_equal(lidar::choose_step(5, 20, [](int s) { return std::labs(s - 12L); }), 12);
    assert_int_equal(lidar::choose_step(5, 20, [](int s) { return s == 8 || s == 14 ? 0L : 3L; }), 8);
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::choose_step(5, 4, [](int) { return 0L; }); }));
}

// --- de-warp --------------------------------------------------------------------------------

void set(DisparityMap &d, FlowField &f, int x, int y, float disp, float u, float v) {
    d(y, x) = disp;
    f.u(y, x) = u;
    f.v(y, x) = v;
    f.valid(y, x) = 1;
}

void test_dewarp_occlusion(void **) {
    DisparityMap d(4, 8, kInvalidDisparity);
    FlowField f = FlowField::zeros(8, 4);
    set(d, f, 1, 1, 10, 2, 0);     // -> (3, 1), farther ...
    set(d, f, 3, 1, 20, 0, 0);     // ... than this one, which stays: the nearer wins
    set(d, f, 4, 2, 5, 0, 0);      // first in scan order, farther ...
    set(d, f, 5, 2, 30, -1, 0);    // ... loses against this later, nearer one at (4, 2)
    set(d, f, 0, 3, 40, 1.6f, 0);  // rounds to (2, 3): nearer ...
    set(d, f, 2, 3, 8, 0, 0.4f);   // ... than this one (rounds to (2, 3) too)
    set(d, f, 7, 0, 9, 3, 0);      // leaves the image
    d(0, 0) = 50;                  // valid disparity without flow: ignored
    const lidar::DewarpResult r = lidar::dewarp_to_t1(d, f);
    assert_int_equal(r.moved, 7);
    assert_int_equal(r.outside, 1);
    assert_int_equal(r.collisions, 3);
    assert_int_equal(cv::countNonZero(r.disp >= 0), 3);
    assert_true(r.disp(1, 3) == 20 && r.source(1, 3) == cv::Vec2i(3, 1));
    assert_true(r.disp(2, 4) == 30 && r.source(2, 4) == cv::Vec2i(5, 2));
    assert_true(r.disp(3, 2) == 40 && r.source(3, 2) == cv::Vec2i(0, 3));
    assert_true(r.source(0, 0) == cv::Vec2i(-1, -1) && r.disp(0, 0) < 0);

    assert_true(throws_code(ErrorCode::SizeMismatch, [&] { lidar::dewarp_to_t1(DisparityMap(4, 7, 1.0f), f); }));
    DisparityMap inf = d.clone();
    inf(1, 1) = std::numeric_limits<float>::infinity();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::dewarp_to_t1(inf, f); }));
    FlowField nanf = f;
    nanf.u = f.u.clone();
    nanf.u(1, 3) = std::numeric_limits<float>::quiet_NaN();
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::dewarp_to_t1(d, nanf); }));
    lidar::DewarpOptions o;
    o.gap_min_nearer = 0;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::dewarp_to_t1(d, f, o); }));
}

// A nearer surface that comes closer grows from t0 to t1 and can splat with a one-pixel gap; a
// farther point that lands in the gap would be hidden from a beam at t1 and must go, while a
// farther point beside the surface stays.
void test_dewarp_gap_in_nearer_surface(void **) {
    DisparityMap d(9, 12, kInvalidDisparity);
    FlowField f = FlowField::zeros(12, 9);
    // Nearer surface: the 5x5 block (1..5, 1..5) at d = 50 except its centre (3, 3).
    for (int y = 1; y <= 5; ++y)
        for (int x = 1; x <= 5; ++x)
            if (x != 3 || y != 3) set(d, f, x, y, 50, 0, 0);
    set(d, f, 9, 7, 5, -6, -4);   // farther point -> (3, 3): 8 nearer neighbours, a gap
    set(d, f, 10, 3, 5, -4, 0);   // farther point -> (6, 3): 3 nearer neighbours, visible
    const lidar::DewarpResult r = lidar::dewarp_to_t1(d, f);
    assert_true(r.disp(3, 6) == 5 && r.source(3, 6) == cv::Vec2i(10, 3));
    assert_true(r.disp(3, 3) < 0 && r.source(3, 3) == cv::Vec2i(-1, -1));
    assert_int_equal(r.gaps, 1);
    assert_int_equal(cv::countNonZero(r.disp == 50), 24);
    lidar::DewarpOptions keep;
    keep.gap_min_nearer = 9;  // gap test off
    const lidar::DewarpResult k = lidar::dewarp_to_t1(d, f, keep);
    assert_true(k.disp(3, 3) == 5 && k.source(3, 3) == cv::Vec2i(9, 7));
    assert_int_equal(k.gaps, 0);
}

// --- paper protocol ---------------------------------------------------------------------------

// Flow chosen so that, without the rejection, every D1 window centre would de-warp from a D0
// sample's neighbourhood: the half-step shift alone does not dissolve the correspondences here.
void test_paper_protocol_rejects_correspondences(void **) {
    const int W = 60, H = 40, step = 10;
    const DisparityMap d0(H, W, 7.0f), d1(H, W, 9.0f);
    FlowField f = FlowField::zeros(W, H);
    f.u.setTo(4.0f);
    f.v.setTo(5.0f);
    f.valid.setTo(1);
    lidar::PaperProtocolOptions opt;
    opt.step = step;
    const lidar::PaperSamples s = lidar::sample_paper_protocol(d0, d1, f, opt);
    assert_int_equal(s.step, step);
    assert_int_equal(s.d0.points.size(), (W / step) * (H / step));  // every window centre
    assert_true(!s.d1.points.empty());
    assert_int_equal(s.d1_source.size(), s.d1.points.size());
    int shifted = 0;
    for (std::size_t i = 0; i < s.d1.points.size(); ++i) {
        const LidarPoint &p = s.d1.points[i];
        const cv::Point src = s.d1_source[i];
        assert_true(p.disparity == 9.0f);
        assert_int_equal(src.x, p.x - 4);
        assert_int_equal(src.y, p.y - 5);
        for (const LidarPoint &q : s.d0.points) assert_true(std::max(std::abs(src.x - q.x), std::abs(src.y - q.y)) > 2);
        // Interior D1 windows (centres at multiples of 10) had to move off their centre by 2 px.
        if (p.x % step != 0 || p.y % step != 0) ++shifted;
    }
    assert_true(shifted > 0);
    assert_true(find_point(s.d1, 12, 10) != nullptr);  // window (10, 10): the nearest acceptable pixel

    assert_true(throws_code(ErrorCode::SizeMismatch, [&] { lidar::sample_paper_protocol(d0, DisparityMap(H, W + 1, 1.0f), f); }));
    lidar::PaperProtocolOptions bad;
    bad.step = 3;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_paper_protocol(d0, d1, f, bad); }));
    bad = {};
    bad.target_points = 0;
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_paper_protocol(d0, d1, f, bad); }));
}

// Other placements move both grids by the same whole pixels (their stagger stays), the paper's
// placement is placement 0, and the placements spread over the step.
void test_paper_protocol_placements(void **) {
    const int W = 60, H = 40, step = 10;
    const DisparityMap d0(H, W, 7.0f), d1(H, W, 9.0f);
    FlowField f = FlowField::zeros(W, H);
    f.valid.setTo(1);
    lidar::PaperProtocolOptions opt;
    opt.step = step;
    const lidar::PaperSamples paper = lidar::sample_paper_protocol(d0, d1, f, opt);
    opt.phase = lidar::placement_phase(0);
    const lidar::PaperSamples first = lidar::sample_paper_protocol(d0, d1, f, opt);
    assert_int_equal(first.d0.points.size(), paper.d0.points.size());
    for (std::size_t i = 0; i < paper.d0.points.size(); ++i) {
        assert_int_equal(first.d0.points[i].x, paper.d0.points[i].x);
        assert_int_equal(first.d0.points[i].y, paper.d0.points[i].y);
    }
    for (const LidarPoint &p : paper.d0.points) assert_true(p.x % step == 5 && p.y % step == 5);
    for (const LidarPoint &p : paper.d1.points) assert_true(p.x % step == 0 && p.y % step == 0);

    opt.phase = cv::Point2d(0.3, 0.74);  // 3 and 7 px at this step
    const lidar::PaperSamples moved = lidar::sample_paper_protocol(d0, d1, f, opt);
    assert_int_equal(moved.d0.points.size(), (W / step) * (H / step));
    assert_true(!moved.d1.points.empty());
    for (const LidarPoint &p : moved.d0.points) assert_true(p.x % step == 8 && p.y % step == 2);
    for (const LidarPoint &p : moved.d1.points) assert_true(p.x % step == 3 && p.y % step == 7);

    // The first 64 placements: distinct, inside the unit square, and every quadrant holds a
    // fair share (a lattice-like sequence, not clustered draws).
    int quadrant[4] = {0, 0, 0, 0};
    std::vector<cv::Point2d> seen;
    for (int j = 0; j < 64; ++j) {
        const cv::Point2d q = lidar::placement_phase(j);
        assert_true(q.x >= 0 && q.x < 1 && q.y >= 0 && q.y < 1);
        for (const cv::Point2d &o : seen) assert_true(std::abs(o.x - q.x) + std::abs(o.y - q.y) > 1e-6);
        seen.push_back(q);
        ++quadrant[(q.x >= 0.5) + 2 * (q.y >= 0.5)];
    }
    assert_true(seen[0].x == 0 && seen[0].y == 0);
    for (int n : quadrant) assert_true(n >= 12 && n <= 20);

    assert_true(throws_code(ErrorCode::InvalidArgument, [] { lidar::placement_phase(-1); }));
    for (const cv::Point2d bad : {cv::Point2d(1.0, 0), cv::Point2d(0, -0.1),
                                  cv::Point2d(std::numeric_limits<double>::quiet_NaN(), 0)}) {
        opt.phase = bad;
        assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_paper_protocol(d0, d1, f, opt); }));
    }
}

void test_paper_protocol_real(void **) {
    const std::string root = kitti_or_skip();
    if (root.empty()) skip();
    const io::KittiLayout L{root};
    const std::vector<std::string> ids = L.frame_ids();
    double mean0 = 0, mean1 = 0;
    for (const std::string &id : ids) {
        const DisparityMap d0 = io::read_disparity_png(L.gt_disp0(id)), d1 = io::read_disparity_png(L.gt_disp1(id));
        const FlowField f = io::read_flow_png(L.gt_flow(id));
        const lidar::PaperSamples s = lidar::sample_paper_protocol(d0, d1, f);
        std::printf("%s: D0 %zu, D1 %zu points, step %d (de-warp: %d moved, %d left the image, %d occluded, %d gaps)\n",
                    id.c_str(), s.d0.points.size(), s.d1.points.size(), s.step, s.dewarp.moved, s.dewarp.outside,
                    s.dewarp.collisions, s.dewarp.gaps);
        mean0 += static_cast<double>(s.d0.points.size()) / ids.size();
        mean1 += static_cast<double>(s.d1.points.size()) / ids.size();
        assert_true(s.d0.width == d0.cols && s.d1.height == d0.rows);
        for (const LidarPoint &p : s.d0.points) assert_true(disparity_valid(d0(p.y, p.x)) && d0(p.y, p.x) == p.disparity);
        for (std::size_t i = 0; i < s.d1.points.size(); ++i) {
            const LidarPoint &p = s.d1.points[i];
            const cv::Point src = s.d1_source[i];
            // The sample is the ground-truth t1 disparity of its source, de-warped by the GT flow.
            assert_true(d1(src.y, src.x) == p.disparity && f.valid(src.y, src.x));
            assert_int_equal(static_cast<int>(std::floor(src.x + f.u(src.y, src.x) + 0.5)), p.x);
            assert_int_equal(static_cast<int>(std::floor(src.y + f.v(src.y, src.x) + 0.5)), p.y);
            for (const LidarPoint &q : s.d0.points)
                assert_true(std::max(std::abs(src.x - q.x), std::abs(src.y - q.y)) > 2);
        }
        // Deterministic.
        const lidar::PaperSamples again = lidar::sample_paper_protocol(d0, d1, f);
        assert_int_equal(again.step, s.step);
        assert_int_equal(again.d1.points.size(), s.d1.points.size());
        for (std::size_t i = 0; i < s.d0.points.size(); ++i) assert_int_equal(again.d0.points[i].x, s.d0.points[i].x);
        // Another placement still gives about N points per map, on other pixels.
        lidar::PaperProtocolOptions other;
        other.phase = lidar::placement_phase(3);
        const lidar::PaperSamples o = lidar::sample_paper_protocol(d0, d1, f, other);
        assert_true(o.d0.points.size() >= 60 && o.d0.points.size() <= 120);
        assert_true(o.d1.points.size() >= 60 && o.d1.points.size() <= 120);
        int shared = 0;
        for (const LidarPoint &p : o.d0.points) shared += find_point(s.d0, p.x, p.y) != nullptr;
        assert_true(shared < static_cast<int>(o.d0.points.size()) / 4);
    }
    std::printf("mean over %zu frames: D0 %.1f, D1 %.1f points\n", ids.size(), mean0, mean1);
    assert_true(mean0 >= 70 && mean0 <= 110);
    assert_true(mean1 >= 70 && mean1 <= 110);
}

// --- Velodyne protocol -------------------------------------------------------------------------

std::vector<io::VelodynePoint> ring_scan(int rings, int per_ring) {
    std::vector<io::VelodynePoint> pts;
    for (int r = 0; r < rings; ++r)
        for (int i = 0; i < per_ring; ++i) {
            const double az = -M_PI + (i + 0.5) * 2 * M_PI / per_ring;
            const double el = (2.0 - 0.4 * r) * M_PI / 180;
            pts.push_back({static_cast<float>(20 * std::cos(az) * std::cos(el)),
                           static_cast<float>(20 * std::sin(az) * std::cos(el)), static_cast<float>(20 * std::sin(el)),
                           static_cast<float>(r)});  // reflectance carries the true ring here
        }
    return pts;
}

void test_rings_and_beams(void **) {
    const std::vector<io::VelodynePoint> pts = ring_scan(40, 90);
    const std::vector<int> ring = lidar::ring_indices(pts);
    for (std::size_t i = 0; i < pts.size(); ++i) assert_int_equal(ring[i], static_cast<int>(pts[i].reflectance));
    const std::vector<io::VelodynePoint> kept = lidar::keep_beams(pts, 4);  // rings 5, 15, 25, 35
    assert_int_equal(kept.size(), 4 * 90);
    for (const io::VelodynePoint &p : kept) {
        const int r = static_cast<int>(p.reflectance);
        assert_true(r == 5 || r == 15 || r == 25 || r == 35);
    }
    assert_int_equal(lidar::keep_beams(pts, 40).size(), pts.size());
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::keep_beams(pts, 41); }));
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::keep_beams(pts, 0); }));
    // Not ring-ordered: too few turns.
    assert_true(throws_code(ErrorCode::Format, [&] { lidar::ring_indices(ring_scan(3, 90)); }));
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::ring_indices({}); }));
}

void test_velodyne_protocol_real(void **) {
    const std::string root = kitti_or_skip();
    if (root.empty()) skip();
    const io::KittiLayout L{root};
    for (const std::string &id : L.frame_ids()) {
        const io::VelodyneScan scan = io::read_velodyne_bin(L.velodyne(id));
        const io::CamToCamCalib calib = io::read_calib_cam_to_cam(L.calib_cam_to_cam(id));
        const cv::Matx44d T = io::read_calib_velo_to_cam(L.calib_velo_to_cam(id));
        const cv::Size size = io::read_image(L.left(id, 0)).size();

        const std::vector<int> ring = lidar::ring_indices(scan.points);
        const int rings = ring.back() + 1;
        assert_true(rings >= 64 && rings <= 66);  // HDL-64E; first/last turn may be partial

        const lidar::VelodyneSamples all = lidar::sample_velodyne_protocol(scan, calib, T, size);
        assert_int_equal(all.d0.points.size(), all.projected);
        assert_true(all.d1.points.empty() && all.d1.width == size.width && all.d1.height == size.height);
        assert_int_equal(all.step, 0);
        const DisparityMap dense = all.d0.to_map();

        lidar::VelodyneProtocolOptions o16;
        o16.beams = 16;
        const lidar::VelodyneSamples b16 = lidar::sample_velodyne_protocol(scan, calib, T, size, o16);
        const double frac = static_cast<double>(b16.projected) / all.projected;
        assert_true(frac > 0.15 && frac < 0.35);
        // A subset of the beams: each pixel holds the full scan's value or a farther one.
        for (const LidarPoint &p : b16.d0.points) assert_true(dense(p.y, p.x) >= p.disparity);

        lidar::VelodyneProtocolOptions o88;
        o88.target_points = 88;
        const lidar::VelodyneSamples n88 = lidar::sample_velodyne_protocol(scan, calib, T, size, o88);
        assert_true(n88.d0.points.size() >= 80 && n88.d0.points.size() <= 96);
        for (const LidarPoint &p : n88.d0.points) assert_true(dense(p.y, p.x) == p.disparity);
        std::printf("%s: %d rings, %zu projected, %zu with 16 beams, %zu thinned to ~88 (step %d)\n", id.c_str(),
                    rings, all.projected, b16.projected, n88.d0.points.size(), n88.step);

        lidar::VelodyneProtocolOptions bad;
        bad.target_points = -1;
        assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_velodyne_protocol(scan, calib, T, size, bad); }));
        bad = {};
        bad.beams = 65 + 10;
        assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::sample_velodyne_protocol(scan, calib, T, size, bad); }));
    }
}

// --- visibility filter ----------------------------------------------------------------------

void test_visibility_filter_synthetic(void **) {
    // A background at disparity 10 sampled every 2 px, a near box (disparity 40) over x 30-49,
    // y 10-29 sampled the same way, and three background points that the LiDAR saw past the box's
    // edge and that land inside it.
    SparseLidar in{80, 40, {}};
    for (int y = 0; y < 40; y += 2)
        for (int x = 0; x < 80; x += 2) {
            const bool box = x >= 30 && x < 50 && y >= 10 && y < 30;
            in.points.push_back({x, y, box ? 40.0f : 10.0f});
        }
    const std::vector<LidarPoint> hidden = {{31, 11, 10.0f}, {45, 21, 10.5f}, {48, 27, 9.0f}};
    in.points.insert(in.points.end(), hidden.begin(), hidden.end());
    lidar::VisibilityFilterOptions o;  // 13 x 9 window, hidden by d * 1.05 + 1
    o.half_height = 4;  // these points are 2 px apart: the automatic height would be 1 px
    const SparseLidar out = lidar::remove_hidden_points(in, o);
    assert_int_equal(out.width, 80);
    assert_int_equal(out.height, 40);
    for (const LidarPoint &h : hidden) assert_null(find_point(out, h.x, h.y));
    // Every box point stays, and so does every background point farther from the box than the
    // window; background points within the window of the box go (the price of the rule).
    for (const LidarPoint &p : in.points) {
        const bool hid = std::any_of(hidden.begin(), hidden.end(), [&](const LidarPoint &h) { return h.x == p.x && h.y == p.y; });
        if (hid) continue;
        const bool box = p.disparity == 40.0f;
        const bool near_box = p.x >= 30 - 6 && p.x < 50 + 6 && p.y >= 10 - 4 && p.y < 30 + 4;
        const LidarPoint *q = find_point(out, p.x, p.y);
        if (box || !near_box) {
            assert_non_null(q);
            assert_true(q->disparity == p.disparity);
        } else {
            assert_null(q);
        }
    }
    // Input order is kept: the same points reversed come out reversed.
    SparseLidar reversed = in;
    std::reverse(reversed.points.begin(), reversed.points.end());
    const SparseLidar rout = lidar::remove_hidden_points(reversed, o);
    assert_int_equal(rout.points.size(), out.points.size());
    for (size_t i = 0; i < out.points.size(); ++i) {
        const LidarPoint &a = out.points[i], &b = rout.points[out.points.size() - 1 - i];
        assert_true(a.x == b.x && a.y == b.y && a.disparity == b.disparity);
    }
    // Two points on one pixel: the nearer hides the farther, in either order.
    for (const bool near_first : {true, false}) {
        SparseLidar twin{20, 10, {{5, 5, 30.0f}, {5, 5, 10.0f}}};
        if (!near_first) std::swap(twin.points[0], twin.points[1]);
        const SparseLidar kept = lidar::remove_hidden_points(twin, o);
        assert_int_equal(kept.points.size(), 1);
        assert_true(kept.points[0].disparity == 30.0f);
    }
    // A small step in depth (a slanted surface) is not an occlusion: 10 -> 11 is within 10 * 1.05 + 1.
    SparseLidar ramp{40, 10, {}};
    for (int x = 0; x < 40; ++x) ramp.points.push_back({x, 5, 10.0f + 0.1f * static_cast<float>(x)});
    assert_int_equal(lidar::remove_hidden_points(ramp, o).points.size(), ramp.points.size());
    // Sparse points (the paper's ~88, tens of px apart) never share a window.
    SparseLidar sparse{200, 100, {{10, 10, 5.0f}, {30, 10, 60.0f}, {10, 30, 80.0f}, {50, 50, 1.0f}}};
    assert_int_equal(lidar::remove_hidden_points(sparse, o).points.size(), 4);
    // Off: the input as it is; no points: nothing to do.
    lidar::VisibilityFilterOptions off;
    off.enabled = false;
    assert_int_equal(lidar::remove_hidden_points(in, off).points.size(), in.points.size());
    assert_true(lidar::remove_hidden_points(SparseLidar{}, o).points.empty());
}

// half_height 0: the window's half height follows the scan's ring spacing.
void test_visibility_filter_automatic_height(void **) {
    const auto rings = [](int spacing) {
        SparseLidar s{400, 200, {}};
        for (int y = 2; y < 200; y += spacing)
            for (int x = 0; x < 400; x += 2) s.points.push_back({x, y, 10.0f});
        return s;
    };
    assert_int_equal(lidar::auto_half_height(rings(5)), 4);    // a 64-beam scan of KITTI
    assert_int_equal(lidar::auto_half_height(rings(10)), 7);   // 32 beams
    assert_int_equal(lidar::auto_half_height(rings(19)), 13);  // 16 beams
    assert_int_equal(lidar::auto_half_height(rings(40)), lidar::kMaxAutoHalfHeight);
    // Too few points sharing a column to tell: the 64-beam value.
    assert_int_equal(lidar::auto_half_height(SparseLidar{200, 100, {{10, 10, 5.0f}, {10, 40, 6.0f}}}), 4);
    // A far point 12 px below a ring of near ones on 19 px rings is hidden with the automatic
    // height (13 px) and not with the 64-beam one (4 px).
    SparseLidar s = rings(19);
    for (LidarPoint &p : s.points)
        if (p.y == 2 + 19 * 5) p.disparity = 40.0f;  // one near ring
    s.points.push_back({101, 2 + 19 * 5 + 12, 10.0f});
    lidar::VisibilityFilterOptions o;
    assert_null(find_point(lidar::remove_hidden_points(s, o), 101, 2 + 19 * 5 + 12));
    o.half_height = 4;
    assert_non_null(find_point(lidar::remove_hidden_points(s, o), 101, 2 + 19 * 5 + 12));
}

// Few points read their windows' rows, many dilate the map: both keep exactly the points that no
// point of their window (several on one pixel included) hides, as a plain scan of all pairs says.
void test_visibility_filter_sparse_and_dense_agree(void **) {
    std::mt19937 gen(31);
    int sparse_runs = 0, dense_runs = 0;
    for (const int n : {1, 5, 20, 60, 200, 800})
        for (const int hw : {0, 2, 6})
            for (const int hh : {1, 4, 9}) {  // 0 would be the automatic height
                SparseLidar in{120, 60, {}};
                for (int i = 0; i < n; ++i) {
                    LidarPoint p;
                    p.x = static_cast<int>(gen() % 120);
                    p.y = static_cast<int>(gen() % 60);
                    p.disparity = static_cast<float>(gen() % 4000) / 50.0f;  // ties and equal pixels occur
                    in.points.push_back(p);
                    if (gen() % 7 == 0) in.points.push_back({p.x, p.y, p.disparity * 0.5f});
                }
                lidar::VisibilityFilterOptions o;
                o.half_width = hw;
                o.half_height = hh;
                const SparseLidar out = lidar::remove_hidden_points(in, o);
                std::vector<LidarPoint> want;
                for (const LidarPoint &p : in.points) {
                    float m = -1.0f;
                    for (const LidarPoint &q : in.points)
                        if (std::abs(q.x - p.x) <= hw && std::abs(q.y - p.y) <= hh) m = std::max(m, q.disparity);
                    if (!(m > p.disparity * (1.0f + o.ratio) + o.margin)) want.push_back(p);
                }
                assert_true(out.points == want);
                const double visits = static_cast<double>(in.points.size()) * (2 * hh + 1);
                ++(visits * 16 < 120.0 * 60 ? sparse_runs : dense_runs);
            }
    assert_true(sparse_runs > 10);
    assert_true(dense_runs > 10);
}

void test_visibility_filter_rejects_bad_input(void **) {
    const SparseLidar in{20, 10, {{3, 3, 5.0f}}};
    for (const auto &set : std::vector<std::function<void(lidar::VisibilityFilterOptions &)>>{
             [](auto &o) { o.half_width = -1; }, [](auto &o) { o.half_height = 65; },
             [](auto &o) { o.ratio = std::nanf(""); }, [](auto &o) { o.ratio = 11.0f; },
             [](auto &o) { o.margin = -1.0f; }, [](auto &o) { o.margin = std::numeric_limits<float>::infinity(); }}) {
        lidar::VisibilityFilterOptions o;
        set(o);
        assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::remove_hidden_points(in, o); }));
    }
    const SparseLidar outside{20, 10, {{20, 3, 5.0f}}};
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::remove_hidden_points(outside, {}); }));
    const SparseLidar bad_value{20, 10, {{2, 3, std::nanf("")}}};
    assert_true(throws_code(ErrorCode::InvalidArgument, [&] { lidar::remove_hidden_points(bad_value, {}); }));
}

// On the real scans: the points the filter removes are where the scan disagrees with the ground
// truth (the LiDAR saw past an edge), so the share of projected points that are KITTI outliers
// (> 3 px and > 5 %) falls, while most points stay.
void test_visibility_filter_real(void **) {
    const std::string root = kitti_or_skip();
    if (root.empty()) skip();
    const io::KittiLayout L{root};
    for (const std::string &id : L.frame_ids()) {
        const DisparityMap gt = io::read_disparity_png(L.gt_disp0(id));
        const SparseLidar all = project_scan(L, id, gt.size());
        const SparseLidar kept = lidar::remove_hidden_points(all, {});
        const auto outliers = [&](const SparseLidar &s) {
            long n = 0, bad = 0;
            for (const LidarPoint &p : s.points) {
                const float g = gt(p.y, p.x);
                if (!disparity_valid(g)) continue;
                ++n;
                const float e = std::fabs(g - p.disparity);
                bad += e > 3.0f && e > 0.05f * g ? 1 : 0;
            }
            return 100.0 * static_cast<double>(bad) / static_cast<double>(std::max(n, 1L));
        };
        const double before = outliers(all), after = outliers(kept);
        const double share = static_cast<double>(kept.points.size()) / static_cast<double>(all.points.size());
        std::printf("%s: %zu -> %zu points (%.1f %% kept), outliers vs ground truth %.2f -> %.2f %%\n", id.c_str(),
                    all.points.size(), kept.points.size(), 100.0 * share, before, after);
        assert_true(share > 0.8);  // measured 85-90 %
        assert_true(after < 0.25 * before);  // measured 2.1-2.5 -> 0.2-0.3 %
    }
}

}  // namespace

// Image coordinates to pixels: the nearest pixel (the devkit's floor(x + 0.5)) when it lies in
// the image; none otherwise or for coordinates that are not finite.
void test_nearest_pixel(void **) {
    const cv::Size image(160, 64);
    int x = -7, y = -7;
    assert_true(lidar::nearest_pixel(20.4, 30.5, image, x, y) && x == 20 && y == 31);
    assert_true(lidar::nearest_pixel(-0.5, -0.4, image, x, y) && x == 0 && y == 0);
    assert_true(lidar::nearest_pixel(159.4, 63.49, image, x, y) && x == 159 && y == 63);
    for (const auto &p : {cv::Point2d(-0.6, 3), cv::Point2d(159.5, 3), cv::Point2d(3, 63.5),
                          cv::Point2d(std::nan(""), 3), cv::Point2d(3, 1e300)})
        assert_false(lidar::nearest_pixel(p.x, p.y, image, x, y));
}

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_projection_synthetic),
        cmocka_unit_test(test_nearest_pixel),
        cmocka_unit_test(test_projection_matches_ground_truth),
        cmocka_unit_test(test_grid_sampler),
        cmocka_unit_test(test_dewarp_occlusion),
        cmocka_unit_test(test_dewarp_gap_in_nearer_surface),
        cmocka_unit_test(test_paper_protocol_rejects_correspondences),
        cmocka_unit_test(test_paper_protocol_placements),
        cmocka_unit_test(test_paper_protocol_real),
        cmocka_unit_test(test_rings_and_beams),
        cmocka_unit_test(test_velodyne_protocol_real),
        cmocka_unit_test(test_visibility_filter_synthetic),
        cmocka_unit_test(test_visibility_filter_automatic_height),
        cmocka_unit_test(test_visibility_filter_sparse_and_dense_agree),
        cmocka_unit_test(test_visibility_filter_rejects_bad_input),
        cmocka_unit_test(test_visibility_filter_real),
    };
    return cmocka_run_group_tests_name("lidar_inputs", tests, nullptr, nullptr);
}
