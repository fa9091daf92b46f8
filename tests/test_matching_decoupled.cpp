// SPDX-License-Identifier: MIT
// Stage 1's decoupled design (matching/decoupled_matcher.hpp) and the realtime preset built on
// it: what each field holds, that the tracked rigid prior acts, that a stream reuses the newer
// pair's disparity without changing a result, that every preset is independent of the thread
// count, and the machine-sharing rules of core/threads.hpp.
#include <cstring>
#include <thread>
#include <vector>

#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include "consistency/sgm_check.hpp"
#include "core/threads.hpp"
#include "eval/metrics.hpp"
#include "matching/decoupled_matcher.hpp"
#include "pipeline/estimator.hpp"
#include "stereo/guided_sgm.hpp"
#include "synth/scene.hpp"
#include "synth_fields.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::pipeline;

namespace {

synth::SynthScene scene(int width = 320, int height = 96, unsigned seed = 5) {
    return test::render_scene(width, height, seed);
}

FrameInput frame_of(const synth::SynthScene &s) {
    return FrameInput{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, {}};
}

using test::same_field;
using test::same_mat;
using test::sf_outliers;

matching::MatchingOptions decoupled_options() {
    matching::MatchingOptions o = EstimatorOptions::preset("realtime").matching;
    o.threads = 2;
    return o;
}

// d0 is the guided SGM disparity of the t0 pair with its LiDAR points (the measurement on their
// pixels), d1 that of the t1 pair at the flow target; the backward field holds the same roles
// at t1. Without guided_stereo, both disparities are OpenCV's StereoSGBM.
void fields_hold_stereo_and_flow(void **) {
    const synth::SynthScene s = scene();
    const matching::MatchInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    const consistency::SgmOptions sgm;
    const matching::DecoupledResult r = matching::match_decoupled(in, decoupled_options(), sgm, s.camera, true);
    stereo::GuidedSgmOptions g = decoupled_options().stereo;
    g.num_disparities = sgm.num_disparities;
    g.threads = 2;
    assert_true(same_mat(r.sgm0, stereo::guided_sgm(s.left0, s.right0, s.lidar0, g)));
    assert_true(same_mat(r.sgm1, stereo::guided_sgm(s.left1, s.right1, s.lidar1, g)));
    assert_false(same_mat(r.sgm0, stereo::guided_sgm(s.left0, s.right0, SparseLidar{s.left0.cols, s.left0.rows, {}}, g)));
    matching::MatchingOptions plain = decoupled_options();
    plain.guided_stereo = false;
    const matching::DecoupledResult p = matching::match_decoupled(in, plain, sgm, s.camera, false);
    assert_true(same_mat(p.sgm0, consistency::compute_sgm_disparity(s.left0, s.right0, sgm)));
    assert_true(same_mat(p.sgm1, consistency::compute_sgm_disparity(s.left1, s.right1, sgm)));
    const DisparityMap lidar0 = s.lidar0.to_map();
    int valid = 0;
    for (int y = 0; y < s.left0.rows; ++y)
        for (int x = 0; x < s.left0.cols; ++x) {
            if (!r.forward.valid(y, x)) continue;
            ++valid;
            const float d0 = disparity_valid(lidar0(y, x)) ? lidar0(y, x) : r.sgm0(y, x);
            assert_float_equal(r.forward.d0(y, x), d0, 0);
            const int tx = static_cast<int>(std::lround(x + r.forward.u(y, x)));
            const int ty = static_cast<int>(std::lround(y + r.forward.v(y, x)));
            assert_float_equal(r.forward.d1(y, x), r.sgm1(ty, tx), 0);
        }
    assert_true(valid > s.left0.rows * s.left0.cols / 2);  // most pixels get a 4-vector
    assert_int_equal(r.backward.width(), s.left0.cols);
    assert_true(cv::countNonZero(r.backward.valid) > s.left0.rows * s.left0.cols / 2);
    // Without the backward direction nothing of it is computed.
    const matching::DecoupledResult f = matching::match_decoupled(in, decoupled_options(), sgm, s.camera, false);
    assert_true(f.backward.u.empty());
    assert_true(same_field(f.forward, r.forward));
}

// The rigid prior changes where DIS starts (so the option acts); off, the result still holds.
void rigid_prior_acts(void **) {
    const synth::SynthScene s = scene(640, 192, 2);
    const matching::MatchInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    matching::MatchingOptions with = decoupled_options(), without = with;
    assert_true(with.flow.prior_track_step > 0);
    without.flow.prior_track_step = 0;
    const consistency::SgmOptions sgm;
    const auto a = matching::match_decoupled(in, with, sgm, s.camera, false);
    const auto b = matching::match_decoupled(in, without, sgm, s.camera, false);
    assert_false(same_field(a.forward, b.forward));
    // An unknown camera uses the calibration-free model: still a result.
    const auto c = matching::match_decoupled(in, with, sgm, StereoCamera(), false);
    assert_true(cv::countNonZero(c.forward.valid) > 0);
}

// Without a t1 scan, the t1 stereo is guided by the t0 points carried by the camera's motion:
// they land where the t1 camera sees them at its depth (movers aside). With a t1 scan, or the
// option off, the t1 guide is the scan (or nothing).
void t0_points_carried_to_t1(void **) {
    const synth::SynthScene s = scene(640, 192, 2);
    const SparseLidar none{s.left0.cols, s.left0.rows, {}};
    const matching::MatchInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, none};
    const consistency::SgmOptions sgm;
    const matching::DecoupledResult r = matching::match_decoupled(in, decoupled_options(), sgm, s.camera, false);
    assert_true(r.guide1.points.size() > s.lidar0.points.size() / 2);
    size_t right = 0;
    for (const LidarPoint &p : r.guide1.points)
        if (std::fabs(p.disparity - s.camera.disparity_from_depth(s.depth_left1(p.y, p.x))) <= 1.0f) ++right;
    assert_true(right >= r.guide1.points.size() * 8 / 10);
    stereo::GuidedSgmOptions g = decoupled_options().stereo;
    g.num_disparities = sgm.num_disparities;
    g.threads = 2;
    assert_true(same_mat(r.sgm1, stereo::guided_sgm(s.left1, s.right1, r.guide1, g)));
    // The carried guide makes the t1 disparity better than the images alone.
    matching::MatchingOptions off = decoupled_options();
    off.carry_lidar = false;
    const matching::DecoupledResult o = matching::match_decoupled(in, off, sgm, s.camera, false);
    assert_true(o.guide1.points.empty());
    auto wrong = [&](const DisparityMap &d) {
        int n = 0;
        for (int y = 0; y < d.rows; ++y)
            for (int x = 0; x < d.cols; ++x)
                n += !disparity_valid(d(y, x)) ||
                     std::fabs(d(y, x) - s.camera.disparity_from_depth(s.depth_left1(y, x))) > 3.0f;
        return n;
    };
    assert_true(wrong(r.sgm1) < wrong(o.sgm1));
    const matching::MatchInput with_t1{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    assert_true(matching::match_decoupled(with_t1, decoupled_options(), sgm, s.camera, false).guide1.points ==
                s.lidar1.points);
}

// The rigid choice takes, per pixel, either DIS's flow or the rigid prior's (never a mix), and
// only where the t0 disparity exists; off, the flow is DIS's alone.
void rigid_choice_picks_one_of_two_flows(void **) {
    const synth::SynthScene s = scene(640, 192, 2);
    const matching::MatchInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    matching::MatchingOptions on = decoupled_options(), off = on;
    assert_int_equal(on.flow.rigid_choice_radius, 1);
    off.flow.rigid_choice_radius = 0;
    const consistency::SgmOptions sgm;
    const auto a = matching::match_decoupled(in, on, sgm, s.camera, false);
    const auto b = matching::match_decoupled(in, off, sgm, s.camera, false);
    int changed = 0;
    for (int y = 0; y < s.left0.rows; ++y)
        for (int x = 0; x < s.left0.cols; ++x) {
            if (!a.forward.valid(y, x) || !b.forward.valid(y, x)) continue;
            if (a.forward.u(y, x) == b.forward.u(y, x) && a.forward.v(y, x) == b.forward.v(y, x)) continue;
            ++changed;
            assert_true(disparity_valid(a.sgm0(y, x)));
        }
    std::printf("rigid choice: %d of %d pixels take the rigid flow\n", changed, s.left0.rows * s.left0.cols);
    assert_true(changed > 0);
    assert_true(same_mat(a.sgm0, b.sgm0));
}

// Bad inputs are errors, not crashes.
void bad_inputs_are_refused(void **) {
    const synth::SynthScene s = scene();
    const consistency::SgmOptions sgm;
    const matching::MatchInput small{s.left0, s.right0, s.left1(cv::Rect(0, 0, 100, 50)).clone(), s.right1,
                                     s.lidar0, s.lidar1};
    assert_true(test::throws_code(ErrorCode::SizeMismatch, [&] {
        matching::match_decoupled(small, decoupled_options(), sgm, s.camera, true);
    }));
    matching::MatchingOptions bad = decoupled_options();
    bad.flow.patch_stride = bad.flow.patch_size;
    const matching::MatchInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    assert_true(test::throws_code(ErrorCode::InvalidArgument,
                                  [&] { matching::match_decoupled(in, bad, sgm, s.camera, true); }));
    for (int stride : {-1, decoupled_options().flow.patch_size}) {
        bad = decoupled_options();
        bad.flow.backward_patch_stride = stride;
        assert_true(test::throws_code(ErrorCode::InvalidArgument,
                                      [&] { matching::match_decoupled(in, bad, sgm, s.camera, true); }));
    }
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [] { matching::parse_match_method("sgm"); }));
    assert_int_equal(static_cast<int>(matching::parse_match_method("decoupled")),
                     static_cast<int>(matching::MatchMethod::Decoupled));
}

// realtime beats its own image-only run on the synthetic street and stays within a bound.
void realtime_is_accurate(void **) {
    double lidar = 0, image = 0;
    for (uint64_t seed : {1, 2}) {
        const synth::SynthScene s = scene(640, 192, seed);
        EstimatorOptions o = EstimatorOptions::preset("realtime");
        o.threads = 2;
        const double with = sf_outliers(s, Estimator(o).run(frame_of(s)).dense);
        o.use_lidar = false;
        const double without = sf_outliers(s, Estimator(o).run(frame_of(s)).dense);
        std::printf("realtime, scene %d: SF %.2f %% with LiDAR, %.2f %% image-only\n", static_cast<int>(seed), with,
                    without);
        lidar += with / 2;
        image += without / 2;
    }
    assert_true(lidar < image);
    assert_true(lidar < 12.0);
}

// The backward search's own stride changes the backward flow only (the forward-backward check's
// input), never the forward one or the disparities; 0 is the forward's stride.
void backward_stride_acts_on_the_backward_flow(void **) {
    const synth::SynthScene s = scene();
    const matching::MatchInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    const consistency::SgmOptions sgm;
    matching::MatchingOptions o = decoupled_options();
    assert_int_equal(o.flow.backward_patch_stride, 4);  // realtime's
    o.flow.backward_patch_stride = 0;
    const matching::DecoupledResult same = matching::match_decoupled(in, o, sgm, s.camera, true);
    o.flow.backward_patch_stride = o.flow.patch_stride;
    const matching::DecoupledResult explicit_same = matching::match_decoupled(in, o, sgm, s.camera, true);
    assert_true(same_field(same.backward, explicit_same.backward));
    o.flow.backward_patch_stride = o.flow.patch_stride + 2;
    const matching::DecoupledResult coarse = matching::match_decoupled(in, o, sgm, s.camera, true);
    assert_true(same_field(same.forward, coarse.forward));
    assert_true(same_mat(same.sgm0, coarse.sgm0) && same_mat(same.sgm1, coarse.sgm1));
    assert_false(same_field(same.backward, coarse.backward));
}

// Every preset gives the same fields with 1, 2 and 3 threads.
void presets_do_not_depend_on_threads(void **) {
    const synth::SynthScene s = scene();
    const FrameInput in = frame_of(s);
    for (const char *name : {"realtime", "fast", "balanced"}) {
        EstimatorOptions o = EstimatorOptions::preset(name);
        o.matching.min_coarsest_height = 16;
        o.adaptive_threads = false;  // the count asked for, however busy the machine
        o.threads = 1;
        const EstimatorResult one = Estimator(o).run(in);
        for (int threads : {2, 3}) {
            o.threads = threads;
            const EstimatorResult many = Estimator(o).run(in);
            assert_true(same_field(one.forward, many.forward));
            assert_true(same_field(one.backward, many.backward));
            assert_true(same_field(one.after_fb, many.after_fb));
            assert_true(same_field(one.dense, many.dense));
        }
    }
}

// The `paper` preset is the paper's design (the field defaults: the same result); `default` is
// the decoupled design with the LiDAR-guided stereo, and `fast` differs from it only in the DIS
// patch stride and the ternary census (the same result once those are set back).
void paper_preset_is_the_papers_design(void **) {
    const synth::SynthScene s = scene();
    EstimatorOptions paper = EstimatorOptions::preset("paper"), fields;
    assert_true(paper.matching.method == matching::MatchMethod::PatchMatch);
    assert_false(paper.matching.guided_stereo);
    for (EstimatorOptions *o : {&paper, &fields}) {
        o->threads = 2;
        o->matching.min_coarsest_height = 16;
    }
    assert_true(same_field(Estimator(paper).run(frame_of(s)).dense, Estimator(fields).run(frame_of(s)).dense));
    EstimatorOptions def = EstimatorOptions::preset("default"), fast = EstimatorOptions::preset("fast");
    assert_true(def.matching.method == matching::MatchMethod::Decoupled && def.matching.guided_stereo);
    assert_true(EstimatorOptions::preset("realtime").matching.guided_stereo);
    def.threads = fast.threads = 2;
    assert_int_equal(fast.matching.flow.patch_stride, 3);
    assert_true(fast.matching.stereo.ternary_census && fast.matching.stereo.census_threshold == 1);
    assert_false(same_field(Estimator(def).run(frame_of(s)).dense, Estimator(fast).run(frame_of(s)).dense));
    fast.matching.flow.patch_stride = def.matching.flow.patch_stride;
    fast.matching.stereo.ternary_census = def.matching.stereo.ternary_census;
    fast.matching.stereo.census_threshold = def.matching.stereo.census_threshold;
    assert_true(same_field(Estimator(def).run(frame_of(s)).dense, Estimator(fast).run(frame_of(s)).dense));
}

// A stream hands the t1 disparity to the next frame: reused, and the result is a lone run's.
void stream_reuses_the_newer_disparity(void **) {
    const synth::SynthScene a = scene(320, 96, 5);
    FrameInput first = frame_of(a), second = frame_of(a);
    std::swap(second.left0, second.left1);
    std::swap(second.right0, second.right1);
    std::swap(second.lidar0, second.lidar1);
    EstimatorOptions o = EstimatorOptions::preset("realtime");
    o.threads = 2;
    const Estimator e(o);
    StreamCache cache;
    e.run(first, &cache);
    assert_false(cache.last_reused());
    const EstimatorResult streamed = e.run(second, &cache);
    assert_true(cache.last_reused());
    assert_true(same_field(streamed.dense, e.run(second).dense));
    // A frame that does not continue the stream is computed afresh.
    const synth::SynthScene b = scene(320, 96, 6);
    const EstimatorResult other = e.run(frame_of(b), &cache);
    assert_false(cache.last_reused());
    assert_true(same_field(other.dense, e.run(frame_of(b)).dense));
}

// With every CPU kept busy by other processes, a frame runs on one thread; the process's own
// busy threads (OpenCV's or OpenMP's workers) do not count against it.
void threads_follow_the_idle_cpus(void **) {
    cpu_set_t set;
    CPU_ZERO(&set);
    assert_int_equal(sched_getaffinity(0, sizeof(set), &set), 0);
    const int cpus = CPU_COUNT(&set);
    assert_int_equal(threads_for_now(1), 1);
    assert_int_equal(threads_for_now(0), 1);
    const int now = threads_for_now(cpus);
    assert_true(now >= 1 && now <= cpus);
    std::vector<pid_t> busy;
    for (int i = 0; i < cpus; ++i) {
        const pid_t pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
            // Spins until killed. The volatile store keeps the loop: a side-effect-free infinite
            // loop is undefined behaviour, which clang removes, and the child would run on.
            volatile unsigned long spin = 0;
            for (;;) spin = spin + 1;
        }
        busy.push_back(pid);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const int loaded = threads_for_now(cpus);
    for (pid_t pid : busy) kill(pid, SIGKILL);
    for (pid_t pid : busy) waitpid(pid, nullptr, 0);
    std::printf("%d CPUs: %d thread(s) now, %d with every CPU busy in other processes\n", cpus, now, loaded);
    assert_int_equal(loaded, 1);
    // One of our idle workers caught running by the kernel's count and asleep at one of our own
    // reads is still ours, not another process's; the caller always counts as ours.
    assert_int_equal(other_runnable_tasks(2, 2, 1), 0);
    assert_int_equal(other_runnable_tasks(2, 1, 2), 0);
    assert_int_equal(other_runnable_tasks(3, 1, 2), 1);
    assert_int_equal(other_runnable_tasks(2, 0, 0), 1);
    assert_int_equal(other_runnable_tasks(1, 3, 3), 0);
    // Another process runnable for a moment (the first sample) does not take threads when the
    // second sample finds it gone; one that stays does.
    auto samples = [](std::vector<int> seq, int requested, int cpus, int *pauses) {
        size_t next = 0;
        return threads_from_samples(requested, cpus, [&] { return seq.at(next++); }, [&] { ++*pauses; });
    };
    int pauses = 0;
    assert_int_equal(samples({1, 0}, 2, 2, &pauses), 2);
    assert_int_equal(pauses, 1);
    assert_int_equal(samples({1, 1}, 2, 2, &pauses), 1);
    assert_int_equal(samples({0}, 2, 2, &pauses), 2);
    assert_int_equal(samples({-1}, 4, 2, &pauses), 4);
    assert_int_equal(pauses, 2);
    assert_int_equal(samples({2, 1}, 4, 4, &pauses), 3);
    assert_int_equal(samples({1, 3}, 4, 4, &pauses), 3);
    assert_int_equal(samples({5, 5}, 4, 4, &pauses), 1);
    // Releasing the OpenMP pool is harmless outside a region and refused inside one.
    release_openmp_workers();
    int inside = 0;
#pragma omp parallel num_threads(2) reduction(+ : inside)
    {
        release_openmp_workers();
        inside += 1;
    }
    assert_true(inside >= 1);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(fields_hold_stereo_and_flow),   cmocka_unit_test(rigid_prior_acts),
        cmocka_unit_test(bad_inputs_are_refused),        cmocka_unit_test(realtime_is_accurate),
        cmocka_unit_test(presets_do_not_depend_on_threads), cmocka_unit_test(stream_reuses_the_newer_disparity),
        cmocka_unit_test(backward_stride_acts_on_the_backward_flow),
        cmocka_unit_test(threads_follow_the_idle_cpus),  cmocka_unit_test(paper_preset_is_the_papers_design),
        cmocka_unit_test(rigid_choice_picks_one_of_two_flows), cmocka_unit_test(t0_points_carried_to_t1),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
