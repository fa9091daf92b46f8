// SPDX-License-Identifier: MIT
// The evaluator on the real KITTI frames (skipped without LIDARFLOW_KITTI_DIR): ground truth
// scored against itself, and a perturbed estimate (holes, offsets, noise) checked against a
// straightforward re-implementation of the devkit's counting written here.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "core/error.hpp"
#include "eval/kitti_eval.hpp"
#include "io/kitti_layout.hpp"
// cmocka.h defines fail(), which breaks <ios>: include it after every C++ header. Its 1.1.5
// header has no extern "C" of its own, so wrap it here (test_support.hpp's include is then a no-op).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;

namespace {

std::string g_root;

void expect_near(double got, double want, double tol, const char *what) {
    if (!(std::fabs(got - want) <= tol)) fail_msg("%s: got %.12g, want %.12g", what, got, want);
}

void gt_scores_itself(void **) {
    for (const std::string &id : io::KittiLayout{g_root}.frame_ids()) {
        const eval::FrameGroundTruth gt = eval::load_ground_truth(g_root, id);
        assert_true(gt.has_noc);
        const eval::Estimate est{gt.occ.d0, gt.occ.d1, gt.occ.flow};
        // The same pixels scored against noc: the noc maps as their own estimate.
        const eval::FrameGroundTruth noc_only{gt.noc, false, {}};
        const eval::Estimate noc_est{gt.noc.d0, gt.noc.d1, gt.noc.flow};
        for (eval::FillMode mode : {eval::FillMode::Filled, eval::FillMode::EstimateOnly}) {
            const eval::FrameScore s = eval::evaluate_frame(gt, est, {mode, 15});
            const eval::FrameScore n = eval::evaluate_frame(noc_only, noc_est, {mode, 15});
            for (const eval::ComponentScores *c : {&s.dense.occ, &s.dense.noc, &n.dense.occ}) {
                for (const eval::Counts *k : {&c->d0, &c->d1, &c->fl, &c->sf}) {
                    assert_true(k->n_gt > 10000);
                    assert_int_equal(k->n_err, 0);
                    assert_true(k->n_total == k->n_gt);
                    expect_near(k->density_pct(), 100.0, 0.0, "density");
                }
            }
            for (const eval::ComponentScores *c : {&s.dense.occ, &n.dense.occ})
                for (const eval::Counts *k : {&c->d0, &c->d1, &c->fl}) expect_near(k->epe(), 0.0, 0.0, "epe");
            std::printf("%s %-8s occ: D0 %lld D1 %lld Fl %lld SF %lld GT px; noc: SF %lld; occ estimate vs noc GT: "
                        "EPE D0 %.3g D1 %.3g Fl %.3g\n",
                        id.c_str(), mode == eval::FillMode::Filled ? "filled" : "est-only",
                        (long long)s.dense.occ.d0.n_gt, (long long)s.dense.occ.d1.n_gt,
                        (long long)s.dense.occ.fl.n_gt, (long long)s.dense.occ.sf.n_gt,
                        (long long)s.dense.noc.sf.n_gt, s.dense.noc.d0.epe(), s.dense.noc.d1.epe(),
                        s.dense.noc.fl.epe());
        }
    }
}

// ---- reference: the devkit's counting, written out plainly ------------------------------------

bool ref_valid(float d) { return d >= 0; }

// Devkit-style hole filling with a run counter, independent of the library's implementation.
void ref_fill(std::vector<float> &d, std::vector<float> *u2, std::vector<bool> &valid, int w, int h) {
    // dst takes src's value, or the smaller of src's and other's (per component) when other >= 0.
    auto set = [&](int dst, int src, int other = -1) {
        d[dst] = other >= 0 ? std::min(d[src], d[other]) : d[src];
        if (u2) (*u2)[dst] = other >= 0 ? std::min((*u2)[src], (*u2)[other]) : (*u2)[src];
        valid[dst] = true;
    };
    for (int y = 0; y < h; ++y) {
        int count = 0;
        for (int x = 0; x < w; ++x) {
            const int i = y * w + x;
            if (valid[i]) {
                if (count >= 1 && x - count > 0)
                    for (int k = x - count; k < x; ++k) set(y * w + k, y * w + x - count - 1, i);
                count = 0;
            } else {
                ++count;
            }
        }
        for (int x = 0; x < w; ++x)
            if (valid[y * w + x]) {
                for (int k = 0; k < x; ++k) set(y * w + k, y * w + x);
                break;
            }
        for (int x = w - 1; x >= 0; --x)
            if (valid[y * w + x]) {
                for (int k = x + 1; k < w; ++k) set(y * w + k, y * w + x);
                break;
            }
    }
    for (int x = 0; x < w; ++x) {
        for (int y = 0; y < h; ++y)
            if (valid[y * w + x]) {
                for (int k = 0; k < y; ++k) set(k * w + x, y * w + x);
                break;
            }
        for (int y = h - 1; y >= 0; --y)
            if (valid[y * w + x]) {
                for (int k = y + 1; k < h; ++k) set(k * w + x, y * w + x);
                break;
            }
    }
}

struct RefCounts {
    long long gt = 0, est = 0, total = 0, err = 0;
    double sum = 0;
};

struct RefScores {
    RefCounts d0, d1, fl, sf;
};

RefScores ref_score(const eval::GroundTruth &g, const eval::Estimate &e, bool filled, const cv::Mat1b &region) {
    const int w = g.d0.cols, h = g.d0.rows, n = w * h;
    std::vector<float> d0(n), d1(n), fu(n), fv(n);
    std::vector<bool> v0(n), v1(n), vf(n);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int i = y * w + x;
            v0[i] = ref_valid(e.d0(y, x));
            v1[i] = ref_valid(e.d1(y, x));
            vf[i] = e.flow.valid(y, x) != 0;
            d0[i] = v0[i] ? e.d0(y, x) : -1.0f;
            d1[i] = v1[i] ? e.d1(y, x) : -1.0f;
            fu[i] = vf[i] ? e.flow.u(y, x) : 0.0f;
            fv[i] = vf[i] ? e.flow.v(y, x) : 0.0f;
        }
    const std::vector<bool> o0 = v0, o1 = v1, of = vf;
    if (filled) {
        ref_fill(d0, nullptr, v0, w, h);
        ref_fill(d1, nullptr, v1, w, h);
        ref_fill(fu, &fv, vf, w, h);
    }
    RefScores r;
    auto add = [&](RefCounts &c, bool est_ok, bool scored, bool out, double err) {
        ++c.gt;
        c.est += est_ok;
        if (!scored) return;
        ++c.total;
        c.err += out;
        c.sum += err;
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!region(y, x)) continue;
            const int i = y * w + x;
            const float g0 = g.d0(y, x), g1 = g.d1(y, x), gu = g.flow.u(y, x), gv = g.flow.v(y, x);
            const bool gv0 = g0 >= 0, gv1 = g1 >= 0, gvf = g.flow.valid(y, x) != 0;
            const float e0 = std::fabs(g0 - d0[i]), e1 = std::fabs(g1 - d1[i]);
            const float du = gu - fu[i], dv = gv - fv[i];
            const float ef = std::sqrt(du * du + dv * dv), mf = std::sqrt(gu * gu + gv * gv);
            const bool b0 = e0 > 3.0 && e0 / std::fabs(g0) > 0.05;
            const bool b1 = e1 > 3.0 && e1 / std::fabs(g1) > 0.05;
            const bool bf = ef > 3.0 && ef / mf > 0.05;
            if (gv0) add(r.d0, o0[i], filled || o0[i], b0, e0);
            if (gv1) add(r.d1, o1[i], filled || o1[i], b1, e1);
            if (gvf) add(r.fl, of[i], filled || of[i], bf, ef);
            if (gv0 && gv1 && gvf) add(r.sf, o0[i], filled || (o0[i] && o1[i] && of[i]), b0 || b1 || bf, 0);
        }
    return r;
}

void expect_same(const eval::Counts &c, const RefCounts &r, const char *what) {
    if (c.n_gt != r.gt || c.n_est != r.est || c.n_total != r.total || c.n_err != r.err)
        fail_msg("%s: library gt=%lld est=%lld total=%lld err=%lld, reference %lld %lld %lld %lld", what,
                 (long long)c.n_gt, (long long)c.n_est, (long long)c.n_total, (long long)c.n_err, r.gt, r.est,
                 r.total, r.err);
    expect_near(c.abs_err_sum, r.sum, 1e-9 * std::max(1.0, r.sum), what);
}

void expect_same(const eval::ComponentScores &c, const RefScores &r, const char *what) {
    const std::string w(what);
    expect_same(c.d0, r.d0, (w + " d0").c_str());
    expect_same(c.d1, r.d1, (w + " d1").c_str());
    expect_same(c.fl, r.fl, (w + " fl").c_str());
    expect_same(c.sf, r.sf, (w + " sf").c_str());
}

// Deterministic perturbation of the occ ground truth: +5 px on d0 in a block, a d0 hole block
// (over an object boundary: filling matters), integer noise and sparse holes on d1, smooth
// noise on flow.
eval::Estimate perturbed(const eval::GroundTruth &g) {
    eval::Estimate e{g.d0.clone(), g.d1.clone(), {g.flow.u.clone(), g.flow.v.clone(), g.flow.valid.clone()}};
    for (int y = 0; y < g.d0.rows; ++y)
        for (int x = 0; x < g.d0.cols; ++x) {
            if (y >= 150 && y < 250 && x >= 400 && x < 800 && e.d0(y, x) >= 0) e.d0(y, x) += 5.0f;
            if (y >= 200 && y < 230 && x >= 600 && x < 700) e.d0(y, x) = -1.0f;
            if (e.d1(y, x) >= 0) e.d1(y, x) += static_cast<float>((x * 7 + y * 13) % 9 - 4);
            if ((x + y) % 37 == 0) e.d1(y, x) = -1.0f;
            e.flow.u(y, x) += 3.5f * std::sin(0.05f * x);
            e.flow.v(y, x) += 2.5f * std::cos(0.03f * y);
        }
    return e;
}

void perturbed_matches_reference(void **) {
    for (const std::string &id : io::KittiLayout{g_root}.frame_ids()) {
        const eval::FrameGroundTruth gt = eval::load_ground_truth(g_root, id);
        const eval::Estimate est = perturbed(gt.occ);
        const cv::Size size = gt.occ.d0.size();
        // Seeds on a 20 px grid where the d0 GT is valid; windows of 15 x 15 by explicit loops.
        DisparityMap seeds(size, kInvalidDisparity);
        cv::Mat1b seed_mask = cv::Mat1b::zeros(size), window = cv::Mat1b::zeros(size);
        for (int y = 10; y < size.height; y += 20)
            for (int x = 10; x < size.width; x += 20)
                if (gt.occ.d0(y, x) >= 0) {
                    seeds(y, x) = gt.occ.d0(y, x);
                    seed_mask(y, x) = 1;
                    for (int yy = std::max(0, y - 7); yy <= std::min(size.height - 1, y + 7); ++yy)
                        for (int xx = std::max(0, x - 7); xx <= std::min(size.width - 1, x + 7); ++xx)
                            window(yy, xx) = 1;
                }
        const cv::Mat1b all = cv::Mat1b::ones(size);
        for (bool filled : {true, false}) {
            const eval::EvalOptions opt{filled ? eval::FillMode::Filled : eval::FillMode::EstimateOnly, 15};
            const eval::FrameScore s = eval::evaluate_frame(gt, est, opt, &seeds, id);
            expect_same(s.dense.occ, ref_score(gt.occ, est, filled, all), "dense occ");
            expect_same(s.dense.noc, ref_score(gt.noc, est, filled, all), "dense noc");
            expect_same(s.seeds.occ, ref_score(gt.occ, est, filled, seed_mask), "seeds occ");
            expect_same(s.window.occ, ref_score(gt.occ, est, filled, window), "window occ");
            expect_same(s.window_excl_seeds.noc, ref_score(gt.noc, est, filled, window & (seed_mask == 0)),
                        "window-seeds noc");
            assert_int_equal(s.n_seeds, cv::countNonZero(seed_mask));
            const eval::ComponentScores &o = s.dense.occ;
            assert_true(o.d0.n_err > 0 && o.d1.n_err > 0 && o.fl.n_err > 0);
            std::printf("%s %-8s occ: D0 %.2f%% D1 %.2f%% Fl %.2f%% SF %.2f%%, EPE %.3f %.3f %.3f, density "
                        "%.2f %.2f %.2f %.2f; seeds %lld: SF %.2f%% window %.2f%%\n",
                        id.c_str(), filled ? "filled" : "est-only", o.d0.outlier_pct(), o.d1.outlier_pct(),
                        o.fl.outlier_pct(), o.sf.outlier_pct(), o.d0.epe(), o.d1.epe(), o.fl.epe(),
                        o.d0.density_pct(), o.d1.density_pct(), o.fl.density_pct(), o.sf.density_pct(),
                        (long long)s.n_seeds, s.seeds.occ.sf.outlier_pct(), s.window.occ.sf.outlier_pct());
        }
    }
}

void missing_ground_truth_names_file(void **) {
    try {
        eval::load_ground_truth(g_root, "999999");
        fail_msg("expected an Io error");
    } catch (const Error &e) {
        assert_true(e.code() == ErrorCode::Io);
        assert_non_null(std::strstr(e.what(), "disp_occ_0/999999_10.png"));
    }
}

}  // namespace

int main() {
    g_root = test::kitti_dir_or_skip("test_eval_kitti");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(gt_scores_itself),
        cmocka_unit_test(perturbed_matches_reference),
        cmocka_unit_test(missing_ground_truth_names_file),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
