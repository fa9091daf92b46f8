// SPDX-License-Identifier: MIT
// Stage 1 on the shared KITTI frames with the paper's LiDAR protocol: dense (100 %) matching
// stays within the paper's matching-stage SF outlier rate (38.46 %), and LiDAR support lowers
// the D0 outliers on every frame and the SF outliers on average. Skipped without
// LIDARFLOW_KITTI_DIR.
#include "test_support.hpp"

#include <cstdio>

#include "eval/kitti_eval.hpp"
#include "eval/metrics.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "lidar/paper_protocol.hpp"
#include "matching/scene_flow_matcher.hpp"

using namespace lidarflow;
using namespace lidarflow::matching;

namespace {

std::string g_root;

void lidar_beats_image_only(void **) {
    const io::KittiLayout kl{g_root};
    double sf_img = 0, sf_lid = 0;
    const char *ids[] = {"000002", "000003"};
    for (const char *id : ids) {
        const eval::FrameGroundTruth gt = eval::load_ground_truth(g_root, id);
        const lidar::PaperSamples s = lidar::sample_paper_protocol(gt.occ.d0, gt.occ.d1, gt.occ.flow);
        const MatchInput in{io::read_image(kl.left(id, 0)), io::read_image(kl.right(id, 0)),
                            io::read_image(kl.left(id, 1)), io::read_image(kl.right(id, 1)), s.d0, s.d1};
        eval::EvalOptions eo;
        eo.mode = eval::FillMode::Filled;
        double d0[2], sf[2];
        for (int k = 0; k < 2; ++k) {
            MatchingOptions o = MatchingOptions::for_variant(k == 0 ? MatchVariant::ImageOnly : MatchVariant::Full);
            o.threads = 2;
            const MatchResult r = match_scene_flow(in, o, Direction::Forward);
            const eval::FrameScore fs = eval::evaluate_frame(gt, r.dense, eo);
            d0[k] = fs.dense.occ.d0.outlier_pct();
            sf[k] = fs.dense.occ.sf.outlier_pct();
            std::printf("%s %-28s D0 %.2f D1 %.2f Fl %.2f SF %.2f\n", id, variant_name(o.use_lidar ? MatchVariant::Full : MatchVariant::ImageOnly),
                        d0[k], fs.dense.occ.d1.outlier_pct(), fs.dense.occ.fl.outlier_pct(), sf[k]);
            assert_true(sf[k] <= 38.46);
        }
        assert_true(d0[1] < d0[0] - 0.2);
        sf_img += sf[0] / 2;
        sf_lid += sf[1] / 2;
    }
    assert_true(sf_lid < sf_img);
}

}  // namespace

int main() {
    g_root = test::kitti_dir_or_skip("test_matching_kitti");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lidar_beats_image_only),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
