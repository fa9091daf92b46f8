// SPDX-License-Identifier: MIT
// On the synthetic street (exact ground truth), LiDAR-supported matching beats image-only
// matching where images carry no signal: the textureless box and the dark shadow.
#include "test_support.hpp"

#include <cstdio>

#include "eval/metrics.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "synth/scene.hpp"

using namespace lidarflow;
using namespace lidarflow::matching;

namespace {

struct RegionErrors {
    long n = 0, d0 = 0, d1 = 0;
    double d0_pct() const { return 100.0 * d0 / n; }
    double d1_pct() const { return 100.0 * d1 / n; }
};

RegionErrors errors(const synth::SynthScene &s, const SceneFlowField &est, const cv::Mat1b &mask) {
    RegionErrors e;
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) {
            if (!mask(y, x) || s.disp0_occ(y, x) < 0 || s.disp1_occ(y, x) < 0) continue;
            ++e.n;
            e.d0 += eval::disparity_outlier(s.disp0_occ(y, x), est.d0(y, x));
            e.d1 += eval::disparity_outlier(s.disp1_occ(y, x), est.d1(y, x));
        }
    return e;
}

void lidar_helps_where_images_fail(void **) {
    for (uint64_t seed : {1u, 2u}) {
        synth::SynthConfig c;
        c.seed = seed;
        c.threads = 2;
        const synth::SynthScene s = synth::render(c);
        const MatchInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1};
        MatchingOptions im = MatchingOptions::for_variant(MatchVariant::ImageOnly);
        MatchingOptions li = MatchingOptions::for_variant(MatchVariant::Full);
        im.threads = li.threads = 2;
        const MatchResult ri = match_scene_flow(in, im, Direction::Forward);
        const MatchResult rl = match_scene_flow(in, li, Direction::Forward);
        cv::Mat1b both = s.textureless_mask | s.shadow_mask;
        const RegionErrors ti = errors(s, ri.dense, s.textureless_mask), tl = errors(s, rl.dense, s.textureless_mask);
        const RegionErrors bi = errors(s, ri.dense, both), bl = errors(s, rl.dense, both);
        std::printf("seed %d textureless (%ld px): D0 %.1f -> %.1f, D1 %.1f -> %.1f; textureless+shadow (%ld px): "
                    "D0 %.1f -> %.1f, D1 %.1f -> %.1f\n",
                    int(seed), ti.n, ti.d0_pct(), tl.d0_pct(), ti.d1_pct(), tl.d1_pct(), bi.n, bi.d0_pct(),
                    bl.d0_pct(), bi.d1_pct(), bl.d1_pct());
        assert_true(ti.n > 1000 && bi.n > ti.n + 1000);
        // Margins well above the seed-to-seed spread of the image-only result.
        assert_true(tl.d0_pct() < ti.d0_pct() - 5.0);
        assert_true(tl.d1_pct() < ti.d1_pct() - 3.0);
        assert_true(bl.d0_pct() < bi.d0_pct() - 2.5);
        assert_true(bl.d1_pct() < bi.d1_pct() - 2.0);
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lidar_helps_where_images_fail),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
