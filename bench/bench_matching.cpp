// SPDX-License-Identifier: MIT
// Benchmark of stage 1 (scene-flow matching, both directions) on KITTI frames: seconds per
// frame (median of --runs), peak RSS, and the dense (Filled, 100 % density) outlier rates of
// the forward result, so speed and accuracy are always quoted together.
//
//   bench_matching --root DIR [--ids 000002,000003] [--variant full|im-only|all]
//                  [--threads 2] [--runs 3] [key=value ...]
// key=value overrides a MatchingOptions field (see apply_override) for experiments.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "eval/kitti_eval.hpp"
#include "eval/metrics.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "lidar/paper_protocol.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "viz/error_map.hpp"

using namespace lidarflow;
using namespace lidarflow::matching;

namespace {

void apply_override(MatchingOptions &o, const std::string &kv) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) throw Error(ErrorCode::InvalidArgument, "expected key=value: " + kv);
    const std::string k = kv.substr(0, eq);
    const double v = std::stod(kv.substr(eq + 1));
    if (k == "iterations") o.iterations = int(v);
    else if (k == "grid_step") o.grid_step = int(v);
    else if (k == "min_coarsest_height") o.min_coarsest_height = int(v);
    else if (k == "max_levels") o.max_levels = int(v);
    else if (k == "stop_ratio") o.stop_ratio = float(v);
    else if (k == "max_flow") o.max_flow = float(v);
    else if (k == "max_disparity") o.max_disparity = float(v);
    else if (k == "patch_radius") o.patch_radius = int(v);
    else if (k == "patch_step") o.patch_step = int(v);
    else if (k == "l1") o.norm = v != 0 ? DescriptorNorm::L1 : DescriptorNorm::L2;
    else if (k == "penalty") o.out_of_image_penalty = float(v);
    else if (k == "cell_size") o.sift.cell_size = int(v);
    else if (k == "dim") o.sift.dim = int(v);
    else if (k == "bits") o.sift.bits = int(v);
    else if (k == "norm_floor") o.sift.norm_floor = float(v);
    else if (k == "window_size") o.window_size = int(v);
    else if (k == "const2_abs") o.const2_abs = float(v);
    else if (k == "const2_rel") o.const2_rel = float(v);
    else if (k == "use_lidar1") o.use_lidar1 = v != 0;
    else if (k == "paper_d1_terms") o.d1_terms = v != 0 ? D1Terms::Paper : D1Terms::ReferenceAnchored;
    else if (k == "keep_disparity_change") o.keep_disparity_change = v != 0;
    else if (k == "const1") o.const1 = v != 0;
    else if (k == "const2") o.const2 = v != 0;
    else if (k == "strip_rows") o.strip_rows = int(v);
    else if (k == "seed") o.random_seed = uint64_t(v);
    else throw Error(ErrorCode::InvalidArgument, "unknown option " + k);
}

long peak_rss_kib() {
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss;
}

struct Frame {
    std::string id;
    MatchInput input;
    eval::FrameGroundTruth gt;
    DisparityMap seeds;
};

}  // namespace

int main(int argc, char **argv) {
    try {
        std::string root, variant = "full", dump;
        std::vector<std::string> ids = {"000002", "000003"};
        int threads = 2, runs = 3;
        std::vector<std::string> overrides;
        for (int i = 1; i < argc; ++i) {
            const std::string a = argv[i];
            auto next = [&]() -> std::string {
                if (i + 1 >= argc) throw Error(ErrorCode::InvalidArgument, a + " needs a value");
                return argv[++i];
            };
            if (a == "--root") root = next();
            else if (a == "--ids") {
                ids.clear();
                std::stringstream ss(next());
                for (std::string t; std::getline(ss, t, ',');) ids.push_back(t);
            } else if (a == "--variant") variant = next();
            else if (a == "--threads") threads = std::stoi(next());
            else if (a == "--runs") runs = std::stoi(next());
            else if (a == "--dump") dump = next();
            else if (a.find('=') != std::string::npos) overrides.push_back(a);
            else throw Error(ErrorCode::InvalidArgument, "unknown argument " + a);
        }
        if (root.empty()) {
            const char *env = std::getenv("LIDARFLOW_KITTI_DIR");
            if (!env) throw Error(ErrorCode::InvalidArgument, "--root or LIDARFLOW_KITTI_DIR needed");
            root = env;
        }
        std::vector<MatchVariant> variants;
        const MatchVariant all[] = {MatchVariant::ImageOnly, MatchVariant::ImLidar, MatchVariant::ImLidarWin,
                                    MatchVariant::ImLidarWinConst1, MatchVariant::Full};
        for (MatchVariant v : all)
            if (variant == "all" || variant == variant_name(v) || (variant == "full" && v == MatchVariant::Full))
                variants.push_back(v);
        if (variants.empty()) throw Error(ErrorCode::InvalidArgument, "unknown variant " + variant);

        io::KittiLayout kl{root};
        std::vector<Frame> frames;
        for (const std::string &id : ids) {
            Frame f;
            f.id = id;
            f.input.left0 = io::read_image(kl.left(id, 0));
            f.input.right0 = io::read_image(kl.right(id, 0));
            f.input.left1 = io::read_image(kl.left(id, 1));
            f.input.right1 = io::read_image(kl.right(id, 1));
            f.gt = eval::load_ground_truth(root, id);
            lidar::PaperSamples s = lidar::sample_paper_protocol(f.gt.occ.d0, f.gt.occ.d1, f.gt.occ.flow);
            f.input.lidar0 = s.d0;
            f.input.lidar1 = s.d1;
            f.seeds = s.d0.to_map();
            frames.push_back(std::move(f));
        }

        std::printf("%-28s %-7s %6s %6s %6s %6s   %7s %7s %7s\n", "variant", "frame", "D0%", "D1%", "Fl%",
                    "SF%", "feat_s", "match_s", "total_s");
        for (MatchVariant v : variants) {
            MatchingOptions opt = MatchingOptions::for_variant(v);
            opt.threads = threads;
            for (const std::string &kv : overrides) apply_override(opt, kv);
            std::vector<eval::FrameScore> scores;
            for (Frame &f : frames) {
                std::vector<double> total, feat, match;
                MatchResult fwd;
                for (int r = 0; r < runs; ++r) {
                    const auto t0 = std::chrono::steady_clock::now();
                    SceneFlowMatcher m(f.input, opt);
                    MatchPair both = m.run_both();  // as the estimator runs stage 1
                    fwd = std::move(both.forward);
                    total.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
                    feat.push_back(m.seconds_features());
                    match.push_back(fwd.seconds_matching + both.backward.seconds_matching);
                }
                auto median = [](std::vector<double> x) {
                    std::sort(x.begin(), x.end());
                    return x[x.size() / 2];
                };
                if (!dump.empty()) {
                    const std::string base = dump + "/" + variant_name(v) + "_" + f.id;
                    io::write_image(base + "_d0err.png", viz::disparity_error_image(fwd.dense.d0, f.gt.occ.d0));
                    io::write_image(base + "_d1err.png", viz::disparity_error_image(fwd.dense.d1, f.gt.occ.d1));
                    FlowField fl{fwd.dense.u, fwd.dense.v, fwd.dense.valid};
                    io::write_image(base + "_flerr.png", viz::flow_error_image(fl, f.gt.occ.flow));
                }
                if (std::getenv("LF_COSTS")) {
                    std::vector<float> c;
                    for (const SeedMatch &sm : fwd.seeds) c.push_back(sm.cost / 9.0f);
                    std::sort(c.begin(), c.end());
                    std::printf("per-sample cost quantiles 10/25/50/75/90/99: %.0f %.0f %.0f %.0f %.0f %.0f\n",
                                c[c.size() / 10], c[c.size() / 4], c[c.size() / 2], c[c.size() * 3 / 4],
                                c[c.size() * 9 / 10], c[c.size() * 99 / 100]);
                }
                eval::EvalOptions eo;
                eo.mode = eval::FillMode::Filled;
                eval::FrameScore s = eval::evaluate_frame(f.gt, fwd.dense, eo, &f.seeds, f.id);
                const auto &c = s.dense.occ;
                std::printf("%-28s %-7s %6.2f %6.2f %6.2f %6.2f   %7.3f %7.3f %7.3f\n", variant_name(v),
                            f.id.c_str(), c.d0.outlier_pct(), c.d1.outlier_pct(), c.fl.outlier_pct(),
                            c.sf.outlier_pct(), median(feat), median(match), median(total));
                scores.push_back(s);
            }
            const eval::Summary sum = eval::summarize(scores);
            const auto &mo = sum.mean_dense.occ;
            std::printf("%-28s %-7s %6.2f %6.2f %6.2f %6.2f\n", variant_name(v), "mean", mo.d0.outlier_pct,
                        mo.d1.outlier_pct, mo.fl.outlier_pct, mo.sf.outlier_pct);
            if (sum.pooled.has_lidar) {
                const auto &w = sum.pooled.window.occ;
                std::printf("%-28s %-7s seeds SF %.2f | window D0 %.2f D1 %.2f Fl %.2f SF %.2f\n", "", "pooled",
                            sum.pooled.seeds.occ.sf.outlier_pct(), w.d0.outlier_pct(), w.d1.outlier_pct(),
                            w.fl.outlier_pct(), w.sf.outlier_pct());
            }
        }
        std::printf("threads %d, runs %d, peak RSS %.1f MiB\n", threads, runs, peak_rss_kib() / 1024.0);
        return 0;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "bench_matching: %s\n", e.what());
        return 1;
    }
}
