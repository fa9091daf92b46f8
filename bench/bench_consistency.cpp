// SPDX-License-Identifier: MIT
// Stages 2-3 (consistency check, clustering, sparsification) on real KITTI frames: seconds and
// peak memory per frame, and the est-only KITTI scores after each step (Table I rows
// "Disp+LiDAR", "disp+LiDAR & backward+LiDAR", "Spars+LiDAR", or the image-only rows).
//
//   bench_consistency --kitti DIR [--frames 000002,000003] [--input matcher|gt]
//                     [--image-only] [--cache DIR] [--threads N] [stage options, see --help]
//
// --input matcher (default): the scene-flow matcher's forward and backward fields (stage 1 is
//   timed separately and not part of the stage 2-3 numbers); --cache keeps them between runs.
// --input gt: a perfect matcher made from the ground truth, then corrupted: Gaussian noise on
//   every value, whole 9x9 tiles shifted by large random offsets (coherent mismatches as real
//   matchers make them) and random matches where there is no ground truth, so the field is
//   100 % dense like the matcher's.
// LiDAR: the paper's protocol (88 points from disp_occ_0 / de-warped disp_occ_1).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "consistency/consistency.hpp"
#include "consistency/ground_truth_fields.hpp"
#include "bench_util.hpp"
#include "core/error.hpp"
#include "eval/kitti_eval.hpp"
#include "eval/metrics.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "lidar/paper_protocol.hpp"
#include "matching/scene_flow_matcher.hpp"

using namespace lidarflow;
using bench::peak_rss_mib;
using bench::reset_peak_rss;

namespace {

struct BenchArgs {
    std::string kitti, cache, input = "matcher";
    std::vector<std::string> frames{"000002", "000003"};
    bool image_only = false;
    int threads = 2;
    consistency::ConsistencyOptions opt;
};

[[noreturn]] void usage(const char *msg) {
    std::fprintf(stderr,
                 "%s\nusage: bench_consistency --kitti DIR [--frames A,B] [--input matcher|gt] [--image-only]\n"
                 "  [--cache DIR] [--threads N] [--window N] [--sgm-max-diff PX] [--keep-unverified 0|1]\n"
                 "  [--fb-flow PX] [--fb-d0 PX] [--fb-d1 PX] [--bilinear] [--cluster-flow PX]\n"
                 "  [--cluster-disp PX] [--cluster-min N] [--cluster-4] [--grid-step N] [--block N]\n",
                 msg);
    std::exit(2);
}

double number(const char *s) {
    char *end = nullptr;
    const double v = std::strtod(s, &end);
    if (!end || *end) usage("bad number");
    return v;
}

BenchArgs parse(int argc, char **argv) {
    BenchArgs a;
    auto &o = a.opt;
    for (int i = 1; i < argc; ++i) {
        const std::string k = argv[i];
        auto val = [&]() -> const char * {
            if (i + 1 >= argc) usage(("missing value for " + k).c_str());
            return argv[++i];
        };
        if (k == "--kitti") a.kitti = val();
        else if (k == "--frames") {
            a.frames.clear();
            std::string s = val();
            for (size_t p = 0; p <= s.size();) {
                const size_t c = std::min(s.find(',', p), s.size());
                a.frames.push_back(s.substr(p, c - p));
                p = c + 1;
            }
        } else if (k == "--input") a.input = val();
        else if (k == "--image-only") a.image_only = true;
        else if (k == "--cache") a.cache = val();
        else if (k == "--threads") a.threads = static_cast<int>(number(val()));
        else if (k == "--window") o.support_window = static_cast<int>(number(val()));
        else if (k == "--sgm-max-diff") o.sgm_max_diff = static_cast<float>(number(val()));
        else if (k == "--keep-unverified") o.sgm_keep_unverified = number(val()) != 0;
        else if (k == "--fb-flow") o.fb_max_flow = static_cast<float>(number(val()));
        else if (k == "--fb-d0") o.fb_max_d0 = static_cast<float>(number(val()));
        else if (k == "--fb-d1") o.fb_max_d1 = static_cast<float>(number(val()));
        else if (k == "--bilinear") o.fb_lookup = consistency::BackwardLookup::Bilinear;
        else if (k == "--cluster-flow") o.cluster_max_flow_step = static_cast<float>(number(val()));
        else if (k == "--cluster-disp") o.cluster_max_disp_step = static_cast<float>(number(val()));
        else if (k == "--cluster-min") o.cluster_min_size = static_cast<int>(number(val()));
        else if (k == "--cluster-4") o.cluster_8_neighbours = false;
        else if (k == "--grid-step") o.grid_step = static_cast<int>(number(val()));
        else if (k == "--block") o.sparsify_block = static_cast<int>(number(val()));
        else usage(("unknown option " + k).c_str());
    }
    if (a.kitti.empty()) usage("--kitti is required");
    if (a.input != "matcher" && a.input != "gt") usage("--input must be matcher or gt");
    return a;
}

// --- raw field cache (bench only: planes as float32 / uint8 with a small header) ---
void save_field(const std::string &path, const SceneFlowField &f) {
    std::ofstream o(path, std::ios::binary);
    const int hdr[2] = {f.width(), f.height()};
    o.write(reinterpret_cast<const char *>(hdr), sizeof hdr);
    for (const cv::Mat1f *m : {&f.u, &f.v, &f.d0, &f.d1, &f.confidence})
        o.write(reinterpret_cast<const char *>(m->ptr<float>()), static_cast<std::streamsize>(m->total() * 4));
    o.write(reinterpret_cast<const char *>(f.valid.ptr<uchar>()), static_cast<std::streamsize>(f.valid.total()));
    if (!o) throw Error(ErrorCode::Io, "cannot write " + path);
}
bool load_field(const std::string &path, SceneFlowField &f) {
    std::ifstream i(path, std::ios::binary);
    if (!i) return false;
    int hdr[2] = {0, 0};
    i.read(reinterpret_cast<char *>(hdr), sizeof hdr);
    if (!i || hdr[0] <= 0 || hdr[1] <= 0 || hdr[0] > 10000 || hdr[1] > 10000) return false;
    f = SceneFlowField::zeros(hdr[0], hdr[1]);
    for (cv::Mat1f *m : {&f.u, &f.v, &f.d0, &f.d1, &f.confidence})
        i.read(reinterpret_cast<char *>(m->ptr<float>()), static_cast<std::streamsize>(m->total() * 4));
    i.read(reinterpret_cast<char *>(f.valid.ptr<uchar>()), static_cast<std::streamsize>(f.valid.total()));
    return static_cast<bool>(i);
}

// Corrupts a ground-truth field the way image matching goes wrong (see the file comment).
void corrupt(SceneFlowField &f, uint64_t seed) {
    cv::RNG rng(seed);
    const int tile = 9;
    for (int ty = 0; ty < f.height(); ty += tile)
        for (int tx = 0; tx < f.width(); tx += tile) {
            const bool wrong = rng.uniform(0.0, 1.0) < 0.3;
            auto offset = [&](float lo, float hi) {
                const float m = rng.uniform(lo, hi);
                return rng.uniform(0, 2) ? m : -m;
            };
            const float ou = offset(5, 30), ov = offset(2, 10), od0 = offset(3, 15), od1 = offset(3, 15);
            for (int y = ty; y < std::min(ty + tile, f.height()); ++y)
                for (int x = tx; x < std::min(tx + tile, f.width()); ++x) {
                    if (!f.valid(y, x)) {  // the matcher is dense: something arbitrary here
                        f.u(y, x) = rng.uniform(-100.f, 100.f);
                        f.v(y, x) = rng.uniform(-30.f, 30.f);
                        f.d0(y, x) = rng.uniform(0.f, 100.f);
                        f.d1(y, x) = rng.uniform(0.f, 100.f);
                        f.valid(y, x) = 1;
                        f.confidence(y, x) = rng.uniform(0.f, 1.f);
                        continue;
                    }
                    f.u(y, x) += static_cast<float>(rng.gaussian(0.3)) + (wrong ? ou : 0.f);
                    f.v(y, x) += static_cast<float>(rng.gaussian(0.3)) + (wrong ? ov : 0.f);
                    f.d0(y, x) = std::max(0.f, f.d0(y, x) + static_cast<float>(rng.gaussian(0.3)) + (wrong ? od0 : 0.f));
                    f.d1(y, x) = std::max(0.f, f.d1(y, x) + static_cast<float>(rng.gaussian(0.3)) + (wrong ? od1 : 0.f));
                    f.confidence(y, x) = rng.uniform(0.f, 1.f);
                }
        }
}

void print_scores(const char *row, const eval::FrameScore &s) {
    const eval::ComponentScores &c = s.dense.occ;
    std::printf("  %-26s D0 %6.2f  D1 %6.2f  Fl %6.2f  SF %6.2f %%   density %6.2f %%\n", row, c.d0.outlier_pct(),
                c.d1.outlier_pct(), c.fl.outlier_pct(), c.sf.outlier_pct(), c.sf.density_pct());
}

}  // namespace

int main(int argc, char **argv) {
    const BenchArgs a = parse(argc, argv);
    try {
        const io::KittiLayout kitti{a.kitti};
        std::vector<eval::FrameScore> scores[3];
        const char *rows[3] = {a.image_only ? "disp (image-only)" : "Disp+LiDAR",
                               a.image_only ? "disp & backward (im-only)" : "disp+LiDAR & backward+LiDAR",
                               a.image_only ? "Spars (image-only)" : "Spars+LiDAR"};
        for (const std::string &id : a.frames) {
            const cv::Mat l0 = io::read_image(kitti.left(id, 0)), r0 = io::read_image(kitti.right(id, 0));
            const cv::Mat l1 = io::read_image(kitti.left(id, 1)), r1 = io::read_image(kitti.right(id, 1));
            const eval::FrameGroundTruth gt = eval::load_ground_truth(a.kitti, id);
            const lidar::PaperSamples samples = lidar::sample_paper_protocol(gt.occ.d0, gt.occ.d1, gt.occ.flow);
            const SparseLidar lidar0 = a.image_only ? SparseLidar{} : samples.d0;

            SceneFlowField forward, backward;
            const std::string tag = std::string(a.image_only ? "io" : "lidar") + "_" + id;
            const std::string cache_f = a.cache.empty() ? "" : a.cache + "/" + tag + "_fwd.bin";
            const std::string cache_b = a.cache.empty() ? "" : a.cache + "/" + tag + "_bwd.bin";
            if (a.input == "gt") {
                consistency::GroundTruthFields g = consistency::fields_from_ground_truth(gt.occ.d0, gt.occ.d1, gt.occ.flow);
                forward = g.forward;
                backward = g.backward;
                corrupt(forward, 1);
                corrupt(backward, 2);
            } else if (!(a.cache.size() && load_field(cache_f, forward) && load_field(cache_b, backward))) {
                matching::MatchInput in{l0, r0, l1, r1, lidar0, a.image_only ? SparseLidar{} : samples.d1};
                matching::MatchingOptions mo = matching::MatchingOptions::for_variant(
                    a.image_only ? matching::MatchVariant::ImageOnly : matching::MatchVariant::Full);
                mo.threads = a.threads;
                const auto t0 = std::chrono::steady_clock::now();
                matching::SceneFlowMatcher matcher(in, mo);
                forward = matcher.run(matching::Direction::Forward).dense;
                backward = matcher.run(matching::Direction::Backward).dense;
                std::printf("%s: stage 1 (forward + backward matching) %.2f s\n", id.c_str(),
                            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
                if (!a.cache.empty()) {
                    std::filesystem::create_directories(a.cache);
                    save_field(cache_f, forward);
                    save_field(cache_b, backward);
                }
            }

            const double rss_before = peak_rss_mib();
            const bool reset = reset_peak_rss();
            const consistency::ConsistencyResult r =
                consistency::run_consistency(forward, backward, l0, r0, lidar0, a.opt);
            const double rss_peak = peak_rss_mib();
            const auto &t = r.seconds;
            const auto &c = r.counts;
            std::printf("%s (%dx%d, %s input, %s, %d LiDAR px): stages 2-3 %.3f s  [SGM %.3f, 2a %.3f, "
                        "cluster %.3f, 2b %.3f, cluster %.3f, sparsify %.3f]\n",
                        id.c_str(), l0.cols, l0.rows, a.input.c_str(), a.image_only ? "image-only" : "LiDAR",
                        c.lidar_pixels, t.total, t.sgm, t.sgm_check, t.sgm_clusters, t.fb_check, t.fb_clusters,
                        t.sparsify);
            std::printf("  peak RSS during stages 2-3: %.1f MiB (%s; before: %.1f MiB)\n", rss_peak,
                        reset ? "peak reset before the stages" : "process peak", rss_before);
            std::printf("  matches: input %lld, 2a %lld, clusters %lld, 2b %lld, clusters %lld, sparse %lld; "
                        "LiDAR motion unreliable %d\n",
                        c.input, c.after_sgm_check, c.after_sgm_clusters, c.after_fb_check, c.after_fb_clusters,
                        c.sparse, c.lidar_motion_unreliable);

            eval::EvalOptions eo;
            eo.mode = eval::FillMode::EstimateOnly;
            eo.window = a.opt.support_window;
            const SceneFlowField *stages[3] = {&r.after_sgm, &r.after_fb, &r.sparse};
            for (int k = 0; k < 3; ++k) {
                scores[k].push_back(eval::evaluate_frame(gt, *stages[k], eo, nullptr, id));
                print_scores(rows[k], scores[k].back());
            }
        }
        std::printf("pooled over %zu frame(s), est-only, occ:\n", a.frames.size());
        for (int k = 0; k < 3; ++k) print_scores(rows[k], eval::summarize(scores[k]).pooled);
    } catch (const Error &e) {
        std::fprintf(stderr, "bench_consistency: %s\n", e.what());
        return 1;
    }
    return 0;
}
