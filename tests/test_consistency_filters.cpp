// SPDX-License-Identifier: MIT
// Stage 2a (SGM check) and stage 2b (forward-backward check) on hand-built fields, the SGM
// reference disparity on a shifted random texture, and input validation.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <new>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include "consistency/consistency.hpp"
#include "consistency/ground_truth_fields.hpp"
#include "core/sanitizers.hpp"
#include "consistency_fixtures.hpp"  // last: brings cmocka

using namespace lidarflow;
using namespace lidarflow::consistency;
using lidarflow::test::constant_field;
using lidarflow::test::error_code_of;
using lidarflow::test::error_message_of;
using lidarflow::test::lidar_at;
using lidarflow::test::matching_backward;

namespace {

constexpr int W = 40, H = 30;

LidarReference no_lidar() { return LidarReference::build(SparseLidar{}, W, H, 15); }

void sgm_check_removes_disagreeing_d0(void **) {
    SceneFlowField f = constant_field(W, H, 1, 0, 10, 10);
    f.d0(5, 5) = 20.0f;   // far off SGM
    f.d0(5, 6) = 11.5f;   // within 2 px
    f.d0(5, 7) = 12.25f;  // just beyond 2 px
    const DisparityMap sgm(H, W, 10.0f);
    ConsistencyOptions opt;
    const SceneFlowField out = sgm_check(f, sgm, no_lidar(), opt);
    assert_int_equal(out.valid(5, 5), 0);
    assert_int_equal(out.valid(5, 6), 1);
    assert_int_equal(out.valid(5, 7), 0);
    assert_int_equal(cv::countNonZero(out.valid), W * H - 2);
    // Survivors carry their values, removed pixels are zeroed.
    assert_true(out.d0(5, 6) == 11.5f && out.u(5, 6) == 1.0f);
    assert_true(out.d0(5, 5) == 0.0f);
    // A looser threshold keeps the 12.25 match.
    opt.sgm_max_diff = 2.5f;
    assert_int_equal(sgm_check(f, sgm, no_lidar(), opt).valid(5, 7), 1);
}

void sgm_check_spares_lidar_and_support_windows(void **) {
    SceneFlowField f = constant_field(W, H, 1, 0, 10, 10);
    // LiDAR at (20, 15), window 5: (20..22, 15) wrong d0 inside, (23, 15) just outside.
    f.d0(15, 20) = 30.0f;
    f.d0(15, 22) = 30.0f;
    f.d0(15, 23) = 30.0f;
    const LidarReference lidar = LidarReference::build(lidar_at(W, H, {{20, 15, 30.0f}}), W, H, 5);
    const DisparityMap sgm(H, W, 10.0f);
    const SceneFlowField out = sgm_check(f, sgm, lidar, ConsistencyOptions{});
    assert_int_equal(out.valid(15, 20), 1);  // the LiDAR pixel
    assert_int_equal(out.valid(15, 22), 1);  // inside its window
    assert_int_equal(out.valid(15, 23), 0);  // outside: checked and removed
    // The same pixels are removed without LiDAR.
    const SceneFlowField image_only = sgm_check(f, sgm, no_lidar(), ConsistencyOptions{});
    assert_int_equal(image_only.valid(15, 20) + image_only.valid(15, 22), 0);
}

void sgm_check_unverified_pixels_follow_option(void **) {
    SceneFlowField f = constant_field(W, H, 1, 0, 10, 10);
    f.d0(8, 8) = 40.0f;
    DisparityMap sgm(H, W, 10.0f);
    sgm(8, 8) = kInvalidDisparity;
    ConsistencyOptions opt;
    assert_int_equal(sgm_check(f, sgm, no_lidar(), opt).valid(8, 8), 0);  // default: no verdict, removed
    opt.sgm_keep_unverified = true;
    assert_int_equal(sgm_check(f, sgm, no_lidar(), opt).valid(8, 8), 1);
    assert_int_equal(cv::countNonZero(sgm_check(f, sgm, no_lidar(), opt).valid), W * H);
}

void sgm_disparity_of_shifted_texture(void **) {
    // Right image = left shifted by 7 px: SGM must find d = 7 almost everywhere, including
    // the left border band that only the padding makes matchable.
    cv::Mat1b left(120, 200);
    cv::RNG rng(7);
    rng.fill(left, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(left, left, {3, 3}, 0.8);
    cv::Mat1b right(left.size());
    for (int y = 0; y < left.rows; ++y)
        for (int x = 0; x < left.cols; ++x) right(y, x) = left(y, std::min(x + 7, left.cols - 1));
    SgmOptions opt;
    opt.num_disparities = 32;
    const DisparityMap d = compute_sgm_disparity(left, right, opt);
    int good = 0, total = 0, border_good = 0;
    for (int y = 10; y < 110; ++y)
        for (int x = 10; x < 185; ++x) {
            ++total;
            if (disparity_valid(d(y, x)) && std::fabs(d(y, x) - 7.0f) <= 0.5f) {
                ++good;
                if (x < 32) ++border_good;
            }
        }
    assert_true(good > 0.95 * total);
    assert_true(border_good > 0.9 * 100 * 22);
    // No disparity may point left of I_r^0.
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < 7; ++x) assert_true(!disparity_valid(d(y, x)) || d(y, x) <= x);
    // Without padding the band [0, 32) has no verdict.
    opt.pad_left_border = false;
    const DisparityMap unpadded = compute_sgm_disparity(left, right, opt);
    assert_int_equal(cv::countNonZero(unpadded(cv::Rect(0, 0, 20, unpadded.rows)) >= 0.0f), 0);

    assert_int_equal(static_cast<int>(error_code_of([&] { compute_sgm_disparity(left, right(cv::Rect(0, 0, 100, 120)).clone()); })),
                     static_cast<int>(ErrorCode::SizeMismatch));
    assert_int_equal(static_cast<int>(error_code_of([&] { compute_sgm_disparity(cv::Mat(), right); })),
                     static_cast<int>(ErrorCode::InvalidArgument));
    cv::Mat1f float_img(left.size(), 0.0f);
    assert_int_equal(static_cast<int>(error_code_of([&] { compute_sgm_disparity(float_img, float_img); })),
                     static_cast<int>(ErrorCode::InvalidArgument));
    opt.num_disparities = 20;  // not a multiple of 16
    assert_int_equal(static_cast<int>(error_code_of([&] { compute_sgm_disparity(left, right, opt); })),
                     static_cast<int>(ErrorCode::InvalidArgument));
}

// Under an address-space limit too tight for SGBM's scratch, compute_sgm_disparity throws
// std::bad_alloc instead of letting OpenCV 4.6 end the process (its BufferArea asserts after a
// failed allocation). In a forked child, so that the limit and a crash stay there.
void sgm_reports_missing_address_space(void **) {
#if LIDARFLOW_SANITIZED
    skip();  // the sanitizers' shadow memory ignores (and breaks under) address-space limits
#else
    fflush(nullptr);
    const pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        cv::Mat1b left(375, 1242), right(375, 1242);
        cv::RNG rng(3);
        rng.fill(left, cv::RNG::UNIFORM, 0, 256);
        rng.fill(right, cv::RNG::UNIFORM, 0, 256);
        (void)compute_sgm_disparity(left(cv::Rect(0, 0, 64, 32)), right(cv::Rect(0, 0, 64, 32)));  // warm up
        std::FILE *f = std::fopen("/proc/self/statm", "r");
        unsigned long pages = 0;
        if (!f || std::fscanf(f, "%lu", &pages) != 1) _exit(3);
        std::fclose(f);
        struct rlimit lim;
        getrlimit(RLIMIT_AS, &lim);
        lim.rlim_cur = static_cast<rlim_t>(pages) * sysconf(_SC_PAGESIZE) + (1 << 20);  // 1 MiB to spare
        if (setrlimit(RLIMIT_AS, &lim) != 0) _exit(3);
        try {
            (void)compute_sgm_disparity(left, right);
        } catch (const std::bad_alloc &) {
            _exit(0);
        } catch (const cv::Exception &e) {
            _exit(e.code == cv::Error::StsNoMem ? 0 : 2);  // a cv::Mat of its own: also clean
        } catch (...) {
            _exit(2);
        }
        _exit(1);  // 1 MiB cannot hold a KITTI-size SGM
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
#endif
}

void forward_backward_keeps_consistent_round_trips(void **) {
    const SceneFlowField f = constant_field(W, H, 3, 1, 10, 9);
    const SceneFlowField b = matching_backward(W, H, 3, 1, 10, 9);
    ConsistencyOptions opt;
    opt.fb_search_radius = 0;
    const ForwardBackwardResult r = forward_backward_check(f, b, no_lidar(), opt);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const bool q_inside = x + 3 < W && y + 1 < H;
            assert_int_equal(r.field.valid(y, x), q_inside ? 1 : 0);  // q outside: unverifiable
            if (q_inside)
                assert_true(r.error(y, x) == 0.0f);
            else
                assert_true(std::isinf(r.error(y, x)));
        }
}

void forward_backward_removes_each_kind_of_mismatch(void **) {
    const SceneFlowField f = constant_field(W, H, 3, 1, 10, 9);
    SceneFlowField b = matching_backward(W, H, 3, 1, 10, 9);
    // p = (x, y) looks up q = (x + 3, y + 1).
    b.u(11, 13) = -5.5f;   // flow round trip off by 2.5 px  -> p (10, 10)
    b.d1(11, 18) = 12.5f;  // d0 vs d1_b off by 2.5          -> p (15, 10)
    b.d0(11, 23) = 6.0f;   // d1 vs d0_b off by 3            -> p (20, 10)
    b.valid(11, 28) = 0;   // nothing to come back to        -> p (25, 10)
    b.v(11, 33) = -2.5f;   // off by 1.5: within 2 px        -> p (30, 10) stays
    ConsistencyOptions opt;  // thresholds fixed here so the test does not follow retuned defaults
    opt.fb_max_flow = opt.fb_max_d0 = opt.fb_max_d1 = 2.0f;
    opt.fb_search_radius = 0;  // B at q only: its consistent neighbours must not rescue p
    const ForwardBackwardResult r = forward_backward_check(f, b, no_lidar(), opt);
    assert_int_equal(r.field.valid(10, 10), 0);
    assert_int_equal(r.field.valid(10, 15), 0);
    assert_int_equal(r.field.valid(10, 20), 0);
    assert_int_equal(r.field.valid(10, 25), 0);
    assert_int_equal(r.field.valid(10, 30), 1);
    assert_float_equal(r.error(10, 30), 1.5f / 2.0f, 1e-6);
    assert_float_equal(r.error(10, 20), 3.0f / 2.0f, 1e-6);
    assert_true(std::isinf(r.error(10, 25)));
    assert_int_equal(cv::countNonZero(r.lidar_motion_unreliable), 0);

    // With the default radius 1 a consistent B pixel next to q rescues p (grid-copied B).
    ConsistencyOptions opt1 = opt;
    opt1.fb_search_radius = 1;
    const ForwardBackwardResult r1 = forward_backward_check(f, b, no_lidar(), opt1);
    assert_int_equal(r1.field.valid(10, 10) + r1.field.valid(10, 15) + r1.field.valid(10, 20), 3);
    assert_int_equal(r1.field.valid(10, 25), 1);
    // ... whose round trip accounts for the offset: B = (-4, -1) one pixel right of q returns
    // exactly to p, while (-3, -1) there misses by 1 px (still within 2 px), so the error is 0.
    SceneFlowField shifted = lidarflow::test::deep_copy(b);
    for (int y = 10; y <= 12; ++y)
        for (int x = 12; x <= 14; ++x) shifted.valid(y, x) = 0;  // q = (13, 11) and around: nothing
    shifted.u(11, 14) = -4.0f;
    shifted.valid(11, 14) = 1;
    const ForwardBackwardResult r2 = forward_backward_check(f, shifted, no_lidar(), ConsistencyOptions{});
    assert_int_equal(r2.field.valid(10, 10), 1);
    assert_float_equal(r2.error(10, 10), 0.0f, 1e-6);
    // Beyond the radius nothing is found.
    shifted.valid(11, 14) = 0;
    assert_int_equal(forward_backward_check(f, shifted, no_lidar(), ConsistencyOptions{}).field.valid(10, 10), 0);
}

void forward_backward_checks_windows_and_lidar_motion(void **) {
    const SceneFlowField f = constant_field(W, H, 3, 1, 10, 9);
    SceneFlowField b = matching_backward(W, H, 3, 1, 10, 9);
    // LiDAR pixels at (10, 10) and (20, 10), window 7; (12, 10) lies in the first window.
    const LidarReference lidar =
        LidarReference::build(lidar_at(W, H, {{10, 10, 10.0f}, {20, 10, 10.0f}}), W, H, 7);
    b.u(11, 13) = -8.0f;   // LiDAR (10, 10): flow inconsistent
    b.u(11, 15) = -8.0f;   // window pixel (12, 10): flow inconsistent
    b.d1(11, 23) = 30.0f;  // LiDAR (20, 10): only d0 disagrees, and d0 is not checked there
    ConsistencyOptions opt;
    opt.fb_search_radius = 0;
    opt.keep_unreliable_lidar = true;
    const ForwardBackwardResult r = forward_backward_check(f, b, lidar, opt);
    assert_int_equal(r.field.valid(10, 10), 1);  // LiDAR pixels are never removed ...
    assert_int_equal(r.lidar_motion_unreliable(10, 10), 1);  // ... but flagged
    assert_int_equal(r.field.valid(10, 12), 0);  // support-window pixels are checked in 2b
    assert_int_equal(r.field.valid(10, 20), 1);
    assert_int_equal(r.lidar_motion_unreliable(10, 20), 0);
    assert_int_equal(cv::countNonZero(r.lidar_motion_unreliable), 1);
    // A LiDAR pixel whose q leaves the image cannot be checked: kept and flagged.
    const LidarReference edge = LidarReference::build(lidar_at(W, H, {{W - 1, 0, 10.0f}}), W, H, 1);
    const ForwardBackwardResult re = forward_backward_check(f, b, edge, opt);
    assert_int_equal(re.field.valid(0, W - 1), 1);
    assert_int_equal(re.lidar_motion_unreliable(0, W - 1), 1);
    // By default (keep_unreliable_lidar = false) the flagged pixel goes, the reliable one stays.
    opt.keep_unreliable_lidar = false;
    const ForwardBackwardResult rd = forward_backward_check(f, b, lidar, opt);
    assert_int_equal(rd.field.valid(10, 10), 0);
    assert_int_equal(rd.lidar_motion_unreliable(10, 10), 1);
    assert_int_equal(rd.field.valid(10, 20), 1);
}

void forward_backward_lookup_modes(void **) {
    // p = (10, 10) with u = 0.5 lands between B columns 10 (u_b = 0) and 11 (u_b = -1):
    // bilinear reads -0.5 (exact round trip), nearest reads column 11 (off by 0.5).
    SceneFlowField f = SceneFlowField::zeros(W, H);
    lidarflow::test::set_match(f, 10, 10, 0.5f, 0, 10, 10);
    SceneFlowField b = constant_field(W, H, 0, 0, 10, 10);
    for (int y = 0; y < H; ++y) b.u(y, 11) = -1.0f;
    ConsistencyOptions opt;
    opt.fb_max_flow = 0.25f;
    opt.fb_search_radius = 0;
    opt.fb_lookup = BackwardLookup::Nearest;
    assert_int_equal(forward_backward_check(f, b, no_lidar(), opt).field.valid(10, 10), 0);
    opt.fb_lookup = BackwardLookup::Bilinear;
    assert_int_equal(forward_backward_check(f, b, no_lidar(), opt).field.valid(10, 10), 1);
    // With an invalid neighbour, bilinear falls back to the nearest pixel.
    b.valid(11, 10) = 0;
    assert_int_equal(forward_backward_check(f, b, no_lidar(), opt).field.valid(10, 10), 0);
}

void ground_truth_fields_round_trip(void **) {
    const int w = 12, h = 8;
    DisparityMap d0(h, w, 10.0f), d1(h, w, 9.0f);
    FlowField flow = FlowField::zeros(w, h);
    flow.u.setTo(2.0f);
    flow.v.setTo(1.0f);
    flow.valid.setTo(1);
    d0(0, 0) = kInvalidDisparity;  // no forward match there
    flow.valid(0, 1) = 0;
    // (5, 3) and (6, 3) land on the same q = (7, 4): the nearer one (larger d1) must win.
    flow.u(3, 6) = 1.0f;
    flow.v(3, 6) = 1.0f;
    d1(3, 6) = 20.0f;
    const GroundTruthFields g = fields_from_ground_truth(d0, d1, flow);
    assert_int_equal(g.forward.valid(0, 0) + g.forward.valid(0, 1), 0);
    assert_int_equal(cv::countNonZero(g.forward.valid), w * h - 2);
    assert_true(g.forward.d1(3, 6) == 20.0f && g.forward.u(2, 2) == 2.0f);
    assert_int_equal(g.backward.valid(4, 7), 1);
    assert_true(g.backward.d0(4, 7) == 20.0f && g.backward.d1(4, 7) == 10.0f);
    assert_true(g.backward.u(4, 7) == -1.0f && g.backward.v(4, 7) == -1.0f);
    assert_int_equal(g.backward.valid(4, 8), 0);  // (6, 3) no longer goes there
    assert_int_equal(g.backward.valid(0, 0), 0);  // nothing lands on the first row / column
    // Every forward match whose target stays inside comes back exactly, except (5, 3), which
    // lost q to the nearer point.
    ConsistencyOptions opt;
    opt.fb_search_radius = 0;
    const ForwardBackwardResult r =
        forward_backward_check(g.forward, g.backward, LidarReference::build(SparseLidar{}, w, h, 1), opt);
    assert_int_equal(r.field.valid(3, 5), 0);
    assert_int_equal(r.field.valid(3, 6), 1);
    assert_int_equal(cv::countNonZero(r.field.valid), (w - 2) * (h - 1) - 2 - 1);
    // Bad input.
    assert_int_equal(static_cast<int>(error_code_of([&] { fields_from_ground_truth(d0, DisparityMap(h, w + 1, 1.0f), flow); })),
                     static_cast<int>(ErrorCode::SizeMismatch));
}

void bad_inputs_throw(void **) {
    const SceneFlowField f = constant_field(W, H, 1, 0, 10, 10);
    const SceneFlowField b = matching_backward(W, H, 1, 0, 10, 10);
    const DisparityMap sgm(H, W, 10.0f);
    const ConsistencyOptions opt;
    auto code = [](auto &&fn) { return static_cast<int>(error_code_of(fn)); };
    const int size = static_cast<int>(ErrorCode::SizeMismatch), arg = static_cast<int>(ErrorCode::InvalidArgument);

    const SceneFlowField small = matching_backward(W - 1, H, 1, 0, 10, 10);
    assert_int_equal(code([&] { forward_backward_check(f, small, no_lidar(), opt); }), size);
    assert_int_equal(code([&] { sgm_check(f, DisparityMap(H + 1, W, 10.0f), no_lidar(), opt); }), size);
    assert_int_equal(code([&] { run_consistency(f, small, sgm, SparseLidar{}, opt); }), size);
    SceneFlowField torn = f;
    torn.d1 = cv::Mat1f(H, W - 2, 0.0f);
    assert_int_equal(code([&] { sgm_check(torn, sgm, no_lidar(), opt); }), size);
    assert_int_equal(code([&] { sgm_check(SceneFlowField{}, sgm, no_lidar(), opt); }), arg);

    // NaN / inf at a valid pixel is rejected, at an invalid pixel it is ignored.
    SceneFlowField nan = lidarflow::test::deep_copy(f);
    nan.u(3, 3) = std::nanf("");
    assert_int_equal(code([&] { sgm_check(nan, sgm, no_lidar(), opt); }), arg);
    assert_int_equal(code([&] { forward_backward_check(f, nan, no_lidar(), opt); }), arg);
    nan.valid(3, 3) = 0;
    assert_int_equal(sgm_check(nan, sgm, no_lidar(), opt).valid(3, 3), 0);
    SceneFlowField inf = lidarflow::test::deep_copy(f);
    inf.confidence(2, 2) = INFINITY;
    assert_int_equal(code([&] { sgm_check(inf, sgm, no_lidar(), opt); }), arg);
    // Every plane, up to the last pixel (the scan's vectorised tail), and the message names it.
    for (cv::Mat1f SceneFlowField::*plane :
         {&SceneFlowField::u, &SceneFlowField::v, &SceneFlowField::d0, &SceneFlowField::d1, &SceneFlowField::confidence}) {
        SceneFlowField bad_plane = lidarflow::test::deep_copy(f);
        bad_plane.valid(H - 1, W - 1) = 1;
        (bad_plane.*plane)(H - 1, W - 1) = -INFINITY;
        const std::string msg = error_message_of([&] { forward_backward_check(f, bad_plane, no_lidar(), opt); });
        assert_non_null(std::strstr(msg.c_str(), ("(" + std::to_string(W - 1) + ", " + std::to_string(H - 1) + ")").c_str()));
    }
    DisparityMap nan_sgm = sgm.clone();
    nan_sgm(4, 4) = std::nanf("");
    assert_int_equal(code([&] { sgm_check(f, nan_sgm, no_lidar(), opt); }), arg);

    // LiDAR: wrong image size, point outside, non-finite or negative disparity, even window.
    assert_int_equal(code([&] { LidarReference::build(lidar_at(W + 1, H, {{1, 1, 5.0f}}), W, H, 15); }), size);
    assert_int_equal(code([&] { LidarReference::build(lidar_at(W, H, {{W, 1, 5.0f}}), W, H, 15); }), arg);
    assert_int_equal(code([&] { LidarReference::build(lidar_at(W, H, {{1, 1, NAN}}), W, H, 15); }), arg);
    assert_int_equal(code([&] { LidarReference::build(lidar_at(W, H, {{1, 1, -2.0f}}), W, H, 15); }), arg);
    assert_int_equal(code([&] { LidarReference::build(SparseLidar{}, W, H, 14); }), arg);
    assert_int_equal(code([&] { run_consistency(f, b, sgm, lidar_at(W, H, {{1, -1, 5.0f}}), opt); }), arg);

    // Options: every threshold must be finite and positive.
    ConsistencyOptions bad = opt;
    bad.sgm_max_diff = 0;
    assert_int_equal(code([&] { sgm_check(f, sgm, no_lidar(), bad); }), arg);
    bad = opt;
    bad.fb_max_d1 = NAN;
    assert_int_equal(code([&] { forward_backward_check(f, b, no_lidar(), bad); }), arg);
    bad = opt;
    bad.cluster_min_size = 0;
    assert_int_equal(code([&] { run_consistency(f, b, sgm, SparseLidar{}, bad); }), arg);
    bad = opt;
    bad.fb_search_radius = -1;
    assert_int_equal(code([&] { forward_backward_check(f, b, no_lidar(), bad); }), arg);
    bad = opt;
    bad.sparsify_support = 2;
    assert_int_equal(code([&] { run_consistency(f, b, sgm, SparseLidar{}, bad); }), arg);
    bad = opt;
    bad.sparsify_block = 0;
    assert_int_equal(code([&] { run_consistency(f, b, sgm, SparseLidar{}, bad); }), arg);

    // Images for SGM must be the fields' size.
    const cv::Mat1b img(H, W + 4, uchar(0));
    assert_int_equal(code([&] { run_consistency(f, b, img, img, SparseLidar{}, opt); }), size);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(sgm_check_removes_disagreeing_d0),
        cmocka_unit_test(sgm_check_spares_lidar_and_support_windows),
        cmocka_unit_test(sgm_check_unverified_pixels_follow_option),
        cmocka_unit_test(sgm_disparity_of_shifted_texture),
        cmocka_unit_test(sgm_reports_missing_address_space),
        cmocka_unit_test(forward_backward_keeps_consistent_round_trips),
        cmocka_unit_test(forward_backward_removes_each_kind_of_mismatch),
        cmocka_unit_test(forward_backward_checks_windows_and_lidar_motion),
        cmocka_unit_test(forward_backward_lookup_modes),
        cmocka_unit_test(ground_truth_fields_round_trip),
        cmocka_unit_test(bad_inputs_throw),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
