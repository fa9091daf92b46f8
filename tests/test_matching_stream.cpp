// SPDX-License-Identifier: MIT
// Streaming reuse of stage 1 and the estimator presets: descriptors of a frame's t1 pair (or a
// first frame's, prepared ahead) are reused by the next frame only when its t0 pair is
// pixel-identical, and reuse never changes a result; presets are named, distinct and validated.
#include "test_support.hpp"

#include <string>

#include "core/error.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "pipeline/estimator.hpp"
#include "synth/scene.hpp"

using namespace lidarflow;
using namespace lidarflow::matching;

namespace {

const synth::SynthScene &scene() {
    static const synth::SynthScene s = [] {
        synth::SynthConfig c;
        c.width = 160;
        c.height = 80;
        c.seed = 11;
        c.threads = 1;
        c.lidar_points = 40;
        return synth::render(c);
    }();
    return s;
}

MatchingOptions small() {
    MatchingOptions o;
    o.min_coarsest_height = 20;
    o.threads = 2;
    return o;
}

bool same_field(const SceneFlowField &a, const SceneFlowField &b) {
    const cv::Mat1f *fa[] = {&a.u, &a.v, &a.d0, &a.d1, &a.confidence};
    const cv::Mat1f *fb[] = {&b.u, &b.v, &b.d0, &b.d1, &b.confidence};
    for (int i = 0; i < 5; ++i)
        if (cv::norm(*fa[i], *fb[i], cv::NORM_INF) != 0) return false;
    return cv::norm(a.valid, b.valid, cv::NORM_INF) == 0;
}

// Frame k+1 = the time-reversed pair: its t0 images are frame k's t1 images.
void matcher_reuses_t1_of_previous_frame(void **) {
    const auto &s = scene();
    const MatchInput fwd{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    const MatchInput rev{s.left1, s.right1, s.left0, s.right0, s.lidar1, s.lidar0};
    SceneFlowMatcher first(fwd, small());
    assert_false(first.reused_t0());
    SceneFlowMatcher cached(rev, small(), first.features_t1());
    assert_true(cached.reused_t0());
    SceneFlowMatcher fresh(rev, small());
    for (Direction d : {Direction::Forward, Direction::Backward})
        assert_true(same_field(cached.run(d).dense, fresh.run(d).dense));

    // Not the same images (one pixel differs) or other descriptor settings: recomputed.
    cv::Mat changed = s.left1.clone();
    changed.ptr<uint8_t>(3)[5] ^= 1;
    const MatchInput other{changed, s.right1, s.left0, s.right0, s.lidar1, s.lidar0};
    assert_false(SceneFlowMatcher(other, small(), first.features_t1()).reused_t0());
    MatchingOptions o64 = small();
    o64.sift.dim = 64;
    assert_false(SceneFlowMatcher(rev, o64, first.features_t1()).reused_t0());
    MatchingOptions packed = small();
    packed.sift.bits = 4;
    assert_false(SceneFlowMatcher(rev, packed, first.features_t1()).reused_t0());
    // Only the full resolution is kept: another pyramid depth reuses it and still matches as a
    // fresh matcher does.
    MatchingOptions fewer = small();
    fewer.max_levels = 2;
    SceneFlowMatcher shallow(rev, fewer, first.features_t1());
    assert_true(shallow.reused_t0());
    SceneFlowMatcher shallow_fresh(rev, fewer);
    assert_true(same_field(shallow.run(Direction::Forward).dense, shallow_fresh.run(Direction::Forward).dense));
}

// run_both puts the coarse levels into the t1 pair's full-resolution buffers and frees them
// before it computes the full resolution's descriptors; its results are those of the two single
// runs (8-bit and packed descriptors, fresh and recycled buffers), and the matcher stays usable
// after it.
void run_both_equals_single_runs(void **) {
    const auto &s = scene();
    const MatchInput fwd{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    for (int levels : {1, 3})
        for (int bits : {8, 4})
            for (bool recycled : {false, true}) {
                MatchingOptions o = small();
                o.max_levels = levels;
                o.sift.bits = bits;
                std::shared_ptr<StereoFeatures> storage;
                if (recycled) {
                    SceneFlowMatcher earlier(fwd, small());
                    earlier.run_both();
                    storage = earlier.release_t0();
                    assert_non_null(storage.get());
                }
                SceneFlowMatcher both(fwd, o, nullptr, storage), single(fwd, o);
                const MatchPair p = both.run_both();
                assert_true(same_field(p.forward.dense, single.run(Direction::Forward).dense));
                assert_true(same_field(p.backward.dense, single.run(Direction::Backward).dense));
                assert_true(same_field(both.run(Direction::Backward).dense, p.backward.dense));
                assert_true(same_field(both.run_both().forward.dense, p.forward.dense));
                assert_true(p.forward.seconds_matching > 0 && p.backward.seconds_matching > 0);
                assert_true(both.seconds_features() > 0);
            }
}

// A matcher hands its t0 pair back for reuse only when nothing else holds it; the next matcher
// writes its t1 descriptors into those buffers, with results equal to a fresh matcher's.
void matcher_recycles_released_storage(void **) {
    const auto &s = scene();
    const MatchInput fwd{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
    const MatchInput rev{s.left1, s.right1, s.left0, s.right0, s.lidar1, s.lidar0};
    SceneFlowMatcher first(fwd, small());
    std::shared_ptr<const StereoFeatures> t1 = first.features_t1();
    std::shared_ptr<StereoFeatures> spare = first.release_t0();
    assert_non_null(spare.get());
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [&] { first.run(Direction::Forward); }));
    const uint8_t *buffer = spare->desc[0].data.data();

    SceneFlowMatcher second(rev, small(), t1, std::move(spare));
    assert_true(second.reused_t0());
    assert_ptr_equal(second.features_t1()->desc[0].data.data(), buffer);
    SceneFlowMatcher fresh(rev, small());
    for (Direction d : {Direction::Forward, Direction::Backward})
        assert_true(same_field(second.run(d).dense, fresh.run(d).dense));
    // t0 of `second` is `t1`, still held here: not handed out for writing.
    assert_null(second.release_t0().get());

    // Packed descriptors written into a released 8-bit pair (their contrast plane is new).
    MatchingOptions packed = small();
    packed.sift.bits = 4;
    SceneFlowMatcher third(fwd, small());
    std::shared_ptr<StereoFeatures> spare8 = third.release_t0();
    assert_non_null(spare8.get());
    SceneFlowMatcher from_spare(fwd, packed, nullptr, std::move(spare8));
    assert_int_equal(from_spare.features_t1()->desc[0].bits, 4);
    SceneFlowMatcher packed_fresh(fwd, packed);
    for (Direction d : {Direction::Forward, Direction::Backward})
        assert_true(same_field(from_spare.run(d).dense, packed_fresh.run(d).dense));
}

void estimator_stream_cache_keeps_results(void **) {
    const auto &s = scene();
    pipeline::EstimatorOptions o;
    o.matching.min_coarsest_height = 20;
    o.threads = 2;
    o.last_stage = pipeline::Stage::Consistency;
    const pipeline::Estimator est(o);
    pipeline::FrameInput fwd{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, StereoCamera{}, {}};
    pipeline::FrameInput rev{s.left1, s.right1, s.left0, s.right0, s.lidar1, s.lidar0, StereoCamera{}, {}};
    pipeline::StreamCache cache;
    est.run(fwd, &cache);
    assert_false(cache.last_reused());
    const pipeline::EstimatorResult streamed = est.run(rev, &cache);
    assert_true(cache.last_reused());
    const pipeline::EstimatorResult alone = est.run(rev);
    assert_true(same_field(streamed.forward, alone.forward));
    assert_true(same_field(streamed.backward, alone.backward));
    assert_true(same_field(streamed.after_fb, alone.after_fb));
    // Frames 3 and 4 write into the buffers frames 1 and 2 released: still the lone results.
    const pipeline::EstimatorResult third = est.run(fwd, &cache);
    assert_true(cache.last_reused());
    assert_true(same_field(third.after_fb, est.run(fwd).after_fb));
    const pipeline::EstimatorResult fourth = est.run(rev, &cache);
    assert_true(same_field(fourth.after_fb, alone.after_fb));
    cache.clear();
    est.run(rev, &cache);
    assert_false(cache.last_reused());
}

// A stream's first frame prepared ahead of its pair: the pair reuses it and its result is the
// lone pair's, bit for bit, for both designs (every stage's field, the ego-motion, the next
// pair); a frame that is not the pair's t0 (another point) is not reused by the decoupled design
// and changes nothing; bad input throws and leaves the cache as it was.
void estimator_first_frame_prepared(void **) {
    const auto &s = scene();
    for (const char *name : {"realtime", "paper"}) {
        pipeline::EstimatorOptions o = pipeline::EstimatorOptions::preset(name);
        o.matching.min_coarsest_height = 20;
        o.threads = 2;
        o.keep_stage_fields = true;
        const pipeline::Estimator est(o);
        // A calibrated rig and a known step: the stream's prior and carried points could apply.
        const pipeline::FrameInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0,
                                      s.lidar1, s.camera,  {},      100000};
        const pipeline::EstimatorResult alone = est.run(in);
        pipeline::StreamCache cache;
        est.prepare_first(s.left0, s.right0, s.lidar0, cache);
        const pipeline::EstimatorResult prepared = est.run(in, &cache);
        assert_true(cache.last_reused());
        assert_true(cache.last_prepared());
        for (auto f : {&pipeline::EstimatorResult::forward, &pipeline::EstimatorResult::backward,
                       &pipeline::EstimatorResult::after_sgm, &pipeline::EstimatorResult::after_fb,
                       &pipeline::EstimatorResult::sparse, &pipeline::EstimatorResult::dense})
            assert_true(same_field(prepared.*f, alone.*f));
        assert_true(alone.ego.valid && alone.ego.calibrated);
        assert_true(prepared.ego_state == alone.ego_state && prepared.ego.inliers == alone.ego.inliers);
        for (int i = 0; i < 9; ++i) assert_true(prepared.ego.R[i] == alone.ego.R[i]);
        for (int i = 0; i < 3; ++i) assert_true(prepared.ego.t[i] == alone.ego.t[i]);
        // The next pair of the stream continues from the prepared one as from any first pair.
        const pipeline::FrameInput back{s.left1, s.right1, s.left0, s.right0, s.lidar1,
                                        s.lidar0, s.camera,  {},      100000};
        pipeline::StreamCache plain;
        est.run(in, &plain);
        assert_true(same_field(est.run(back, &cache).dense, est.run(back, &plain).dense));

        SparseLidar moved = s.lidar0;
        assert_true(!moved.points.empty());
        moved.points[0].x = (moved.points[0].x + 7) % s.left0.cols;
        pipeline::StreamCache other;
        est.prepare_first(s.left0, s.right0, moved, other);
        const pipeline::EstimatorResult with_other = est.run(in, &other);
        assert_true(same_field(with_other.forward, alone.forward));
        assert_true(same_field(with_other.dense, alone.dense));
        // The decoupled design's t0 disparity depends on the points; the descriptors do not. The
        // rest of the frame's preparation (its checks, stage 4's superpixels) is the points' too.
        assert_true(other.last_reused() == (o.matching.method == MatchMethod::PatchMatch));
        assert_false(other.last_prepared());

        pipeline::StreamCache kept;
        est.prepare_first(s.left0, s.right0, s.lidar0, kept);
        const cv::Mat narrow = s.right0.colRange(0, s.right0.cols - 1);
        assert_true(test::throws_code(ErrorCode::SizeMismatch,
                                      [&] { est.prepare_first(s.left0, narrow, s.lidar0, kept); }));
        est.run(in, &kept);
        assert_true(kept.last_reused());
        assert_true(kept.last_prepared());
        est.run(in, &kept);  // spent by its pair
        assert_false(kept.last_prepared());
    }
}

// A stream's pair takes the previous pair's t1 frame, at the processing size, as its t0 only
// when the full-size images and points are the same, and its result is the lone pair's.
void estimator_stream_reuses_previous_frame(void **) {
    const auto &s = scene();
    pipeline::EstimatorOptions o = pipeline::EstimatorOptions::preset("realtime");
    o.threads = 2;
    o.keep_stage_fields = true;
    const pipeline::Estimator est(o);
    assert_true(o.processing_scale < 1.0);
    const pipeline::FrameInput fwd{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, {}, 100000};
    pipeline::FrameInput rev{s.left1, s.right1, s.left0, s.right0, s.lidar1, s.lidar0, s.camera, {}, 100000};
    const auto same_result = [](const pipeline::EstimatorResult &a, const pipeline::EstimatorResult &b) {
        for (auto f : {&pipeline::EstimatorResult::forward, &pipeline::EstimatorResult::backward,
                       &pipeline::EstimatorResult::after_fb, &pipeline::EstimatorResult::dense})
            if (!same_field(a.*f, b.*f)) return false;
        return true;
    };
    pipeline::StreamCache cache;
    est.run(fwd, &cache);
    assert_false(cache.last_reused_frame());
    assert_true(same_result(est.run(rev, &cache), est.run(rev)));
    assert_true(cache.last_reused_frame());
    // One pixel of the next t0 differs from the t1 kept: the frame is reduced again.
    cv::Mat changed = s.left0.clone();
    changed.at<cv::Vec3b>(changed.rows / 2, changed.cols / 2)[1] ^= 0x40;
    const pipeline::FrameInput next{changed, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, {}, 100000};
    assert_true(same_result(est.run(next, &cache), est.run(next)));
    assert_false(cache.last_reused_frame());
    // So is one point more or less.
    rev.lidar0.points.pop_back();
    est.run(next, &cache);
    assert_true(same_result(est.run(rev, &cache), est.run(rev)));
    assert_false(cache.last_reused_frame());
}

void presets(void **) {
    // "paper" is the field defaults (the paper's design); the others are measured from it.
    const pipeline::EstimatorOptions d = pipeline::EstimatorOptions::preset("paper");
    const pipeline::EstimatorOptions plain;
    assert_int_equal(d.matching.grid_step, plain.matching.grid_step);
    assert_int_equal(d.matching.iterations, plain.matching.iterations);
    const pipeline::EstimatorOptions f = pipeline::EstimatorOptions::preset("fast");
    assert_true(f.matching.method == matching::MatchMethod::Decoupled);
    assert_true(d.matching.method == matching::MatchMethod::PatchMatch);
    f.validate();
    assert_true(f.processing_scale < 1.0);
    const pipeline::EstimatorOptions r = pipeline::EstimatorOptions::preset("realtime");
    r.validate();
    assert_true(r.matching.method == matching::MatchMethod::Decoupled);
    assert_true(r.processing_scale < f.processing_scale);
    const pipeline::EstimatorOptions b = pipeline::EstimatorOptions::preset("balanced");
    b.validate();
    assert_true(b.matching.thin_from_level < d.matching.thin_from_level);
    assert_true(b.matching.backward_grid_step > d.matching.grid_step);
    assert_int_equal(d.matching.backward_grid_step, 0);
    assert_true(d.processing_scale == 1.0);
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [] { pipeline::EstimatorOptions::preset("turbo"); }));
    assert_true(test::throws_code(ErrorCode::InvalidArgument, [] { pipeline::EstimatorOptions::preset(""); }));
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(matcher_reuses_t1_of_previous_frame),
        cmocka_unit_test(matcher_recycles_released_storage),
        cmocka_unit_test(run_both_equals_single_runs),
        cmocka_unit_test(estimator_stream_cache_keeps_results),
        cmocka_unit_test(estimator_first_frame_prepared),
        cmocka_unit_test(estimator_stream_reuses_previous_frame),
        cmocka_unit_test(presets),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
