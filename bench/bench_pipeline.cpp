// SPDX-License-Identifier: MIT
// The complete pipeline's speed and accuracy, beside OpenCV's off-the-shelf baseline measured
// in the same run (StereoSGBM for d0 and d1 + DISOpticalFlow for u, v):
//   per-stage and total seconds (median of --runs), peak RSS, KITTI outliers (devkit, filled),
//   for the shared KITTI frames (paper LiDAR protocol) and the built-in synthetic scene.
//
//   bench_pipeline [--root DIR] [--ids A,B] [--runs 3] [--threads 2] [--preset NAME] [--no-synth]
//                  [--no-kitti] [--heap keep|glibc] [--set KEY=VALUE,...] [--lidar paper|velodyne]
//                  [--beams K]
// --lidar velodyne [--beams K]: the KITTI frames with their Velodyne scan (as `lidarflow kitti`)
// instead of the paper's ~88 points. KITTI has no t1 scan, so the stream's time-reversed pairs
// run without LiDAR there: compare the pair column.
// --set: any option key of the C ABI (lidarflow.h), after the preset, as `lidarflow --set`.
// --heap: the heap policy of the project's programs (keep, as the CLI and the bridge) or glibc's
// defaults (as an application that embeds the library without configuring malloc).
// Also measured: a stream (Estimator::run with a StreamCache) alternating each frame pair with its
// time-reversed pair, so every run after the first starts from the previous run's t1 images.
// And a lone pair whose first frame was prepared ahead (Estimator::prepare_first, as the C ABI
// does when a stream starts): the time from its second frame to its result.
// The time ratio line also gives the stream's ratio and that of its stages other than matching
// (what the pipeline would take with a matcher that cost nothing).
// DIR defaults to $LIDARFLOW_KITTI_DIR; without it only the synthetic scene is measured.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "args.hpp"
#include "bench_util.hpp"
#include "heap_policy.hpp"
#include "eval/kitti_eval.hpp"
#include "eval/kitti_runner.hpp"
#include "eval/metrics.hpp"
#include "io/kitti_layout.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/option_assignments.hpp"
#include "synth/scene.hpp"

using namespace lidarflow;
using Clock = std::chrono::steady_clock;

namespace {

struct Case {
    std::string name;
    pipeline::FrameInput input;
    eval::FrameGroundTruth gt;
};

struct Args {
    std::string root;
    std::vector<std::string> ids;
    int runs = 3, threads = 2;
    std::string preset = "default";
    bool synth = true, kitti = true;
    bool keep_heap = true;
    std::vector<std::string> assignments;
    eval::LidarInputOptions lidar;  // KITTI frames: the paper's 88 points, or the scan
};

[[noreturn]] void usage(const char *msg) {
    std::fprintf(stderr, "bench_pipeline: %s\nusage: bench_pipeline [--root DIR] [--ids A,B] [--runs N] "
                         "[--threads N] [--preset NAME] [--no-synth] [--no-kitti] [--heap keep|glibc] [--set K=V,..]\n"
                         "       [--lidar paper|velodyne] [--beams K]\n",
                 msg);
    std::exit(2);
}

Args parse(int argc, char **argv) {
    Args a;
    if (const char *k = std::getenv("LIDARFLOW_KITTI_DIR")) a.root = k;
    for (int i = 1; i < argc; ++i) {
        const std::string k = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) usage(("missing value for " + k).c_str());
            return argv[++i];
        };
        if (k == "--root") a.root = value();
        else if (k == "--ids") a.ids = cli::split_list(value());
        else if (k == "--runs") a.runs = std::atoi(value().c_str());
        else if (k == "--threads") a.threads = std::atoi(value().c_str());
        else if (k == "--preset") a.preset = value();
        else if (k == "--no-synth") a.synth = false;
        else if (k == "--no-kitti") a.kitti = false;
        else if (k == "--set") a.assignments = cli::split_list(value());
        else if (k == "--lidar") {
            const std::string v = value();
            if (v != "paper" && v != "velodyne") usage("--lidar must be paper or velodyne");
            a.lidar.protocol = v == "paper" ? eval::LidarProtocol::Paper : eval::LidarProtocol::Velodyne;
            if (v == "velodyne") a.lidar.points = 0;  // the whole scan unless --beams thins it
        }
        else if (k == "--beams") a.lidar.beams = std::atoi(value().c_str());
        else if (k == "--heap") {
            const std::string v = value();
            if (v != "keep" && v != "glibc") usage("--heap must be keep or glibc");
            a.keep_heap = v == "keep";
        }
        else usage(("unknown option " + k).c_str());
    }
    if (a.runs < 1 || a.threads < 1) usage("--runs and --threads must be >= 1");
    if (a.lidar.beams < 0 || (a.lidar.beams > 0 && a.lidar.protocol != eval::LidarProtocol::Velodyne))
        usage("--beams K (K >= 1) needs --lidar velodyne");
    return a;
}

cv::Mat gray(const cv::Mat &m) {
    if (m.channels() == 1) return m;
    cv::Mat g;
    cv::cvtColor(m, g, cv::COLOR_BGR2GRAY);
    return g;
}

DisparityMap sgbm(const cv::Mat &left, const cv::Mat &right) {
    auto s = cv::StereoSGBM::create(0, 128, 5, 8 * 25, 32 * 25, 1, 0, 10, 100, 2, cv::StereoSGBM::MODE_SGBM_3WAY);
    cv::Mat raw;
    s->compute(gray(left), gray(right), raw);
    DisparityMap d(raw.size());
    for (int y = 0; y < raw.rows; ++y)
        for (int x = 0; x < raw.cols; ++x) {
            const int16_t v = raw.at<int16_t>(y, x);
            d(y, x) = v < 0 ? kInvalidDisparity : v / 16.0f;
        }
    return d;
}

// The baseline: SGBM at t0 and t1, DIS flow, d1 looked up at p + flow (holes stay holes; the
// evaluator fills them as the devkit does).
eval::Estimate opencv_baseline(const pipeline::FrameInput &in) {
    eval::Estimate e;
    e.d0 = sgbm(in.left0, in.right0);
    const DisparityMap d1_t1 = sgbm(in.left1, in.right1);
    cv::Mat2f flow;
    cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM)->calc(gray(in.left0), gray(in.left1), flow);
    e.flow = FlowField::zeros(flow.cols, flow.rows);
    e.d1 = DisparityMap(flow.size(), kInvalidDisparity);
    for (int y = 0; y < flow.rows; ++y)
        for (int x = 0; x < flow.cols; ++x) {
            const cv::Vec2f f = flow(y, x);
            e.flow.u(y, x) = f[0];
            e.flow.v(y, x) = f[1];
            e.flow.valid(y, x) = 1;
            const int x1 = cvRound(x + f[0]), y1 = cvRound(y + f[1]);
            if (x1 >= 0 && y1 >= 0 && x1 < flow.cols && y1 < flow.rows) e.d1(y, x) = d1_t1(y1, x1);
        }
    return e;
}

std::vector<Case> load_cases(const Args &a) {
    std::vector<Case> cases;
    if (a.kitti && !a.root.empty()) {
        const std::vector<std::string> ids = a.ids.empty() ? io::KittiLayout{a.root}.frame_ids() : a.ids;
        for (const std::string &id : ids) {
            eval::KittiFrame f = eval::load_kitti_frame(a.root, id, a.lidar);
            cases.push_back({"kitti " + id, std::move(f.input), eval::load_ground_truth(a.root, id)});
        }
    }
    if (a.synth) {
        const synth::SynthScene s = synth::render(synth::SynthConfig{});
        Case c;
        c.name = "synthetic";
        c.input = {s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, StereoCamera{}, {}};
        c.gt.occ = {s.disp0_occ, s.disp1_occ, s.flow_occ};
        c.gt.has_noc = true;
        c.gt.noc = {s.disp0_noc, s.disp1_noc, s.flow_noc};
        cases.push_back(std::move(c));
    }
    return cases;
}

void print_scores(const char *label, const eval::FrameScore &s, double seconds) {
    const eval::ComponentScores &c = s.dense.occ;
    std::printf("  %-22s D0 %6.2f  D1 %6.2f  Fl %6.2f  SF %6.2f %%   %7.3f s\n", label, c.d0.outlier_pct(),
                c.d1.outlier_pct(), c.fl.outlier_pct(), c.sf.outlier_pct(), seconds);
}

}  // namespace

int run_bench(int argc, char **argv) {
    const Args a = parse(argc, argv);
    const tools::HeapPolicy heap = a.keep_heap ? tools::apply_heap_policy() : tools::HeapPolicy{};
    const std::vector<Case> cases = load_cases(a);
    if (cases.empty()) usage("nothing to measure (no KITTI root and --no-synth)");
    pipeline::EstimatorOptions opt = pipeline::EstimatorOptions::preset(a.preset);
    pipeline::apply_option_assignments(opt, a.assignments);
    opt.threads = a.threads;
    opt.keep_stage_fields = false;  // as the C ABI: only the dense result is read
    const pipeline::Estimator estimator(opt);
    std::string set;
    for (const std::string &kv : a.assignments) set += (set.empty() ? " --set " : ",") + kv;
    std::printf("bench_pipeline: preset %s%s, %d thread(s), median of %d run(s), %u hardware threads, heap: %s\n",
                a.preset.c_str(), set.c_str(), a.threads, a.runs, std::thread::hardware_concurrency(), heap.describe());
    for (const Case &c : cases) {
        std::printf("\n%s (%dx%d, LiDAR %zu + %zu points)\n", c.name.c_str(), c.input.left0.cols, c.input.left0.rows,
                    c.input.lidar0.points.size(), c.input.lidar1.points.size());
        std::map<std::string, std::vector<double>> stage;
        std::vector<std::string> order;
        std::vector<double> total, base;
        int fewer = 0;  // frames adaptive_threads ran on fewer threads than asked
        pipeline::EstimatorResult last;
        eval::Estimate base_est;
        bench::release_free_heap();
        bench::reset_peak_rss();
        const double rss_before = bench::peak_rss_mib();
        for (int r = 0; r < a.runs; ++r) {
            // The C ABI and the bridge copy the output and drop the rest; holding the previous
            // run's six fields (~60 MB on KITTI) through this one would measure the bench.
            last = {};
            last = estimator.run(c.input);
            for (const pipeline::StageTime &t : last.timings) {
                if (!stage.count(t.name)) order.push_back(t.name);
                stage[t.name].push_back(t.seconds);
            }
            total.push_back(last.total_seconds);
            fewer += last.threads < opt.threads;
        }
        const double rss_pipeline = bench::peak_rss_mib();
        // Streaming: pair, reversed pair, pair, ... through one cache (t0 of each = t1 before).
        pipeline::FrameInput rev = c.input;
        std::swap(rev.left0, rev.left1);
        std::swap(rev.right0, rev.right1);
        std::swap(rev.lidar0, rev.lidar1);
        const eval::EvalOptions eo;
        const eval::FrameScore ours = eval::evaluate_frame(c.gt, last.dense, eo);
        last = {};  // the stream's peak is the stream's own
        pipeline::StreamCache cache;
        const bool stream_peak = bench::reset_peak_rss();
        std::vector<double> stream_total;
        std::map<std::string, std::vector<double>> stream_stage;
        int reused = 0;
        for (int r = 0; r <= a.runs; ++r) {
            const pipeline::EstimatorResult sr = estimator.run(r % 2 ? rev : c.input, &cache);
            if (r == 0) continue;  // the first frame of a stream has nothing to reuse
            fewer += sr.threads < opt.threads;
            reused += cache.last_reused() ? 1 : 0;
            stream_total.push_back(sr.total_seconds);
            for (const pipeline::StageTime &t : sr.timings) stream_stage[t.name].push_back(t.seconds);
        }
        // Without a reset (no /proc/self/clear_refs) the high-water mark is the whole process's.
        const std::string rss_stream =
            stream_peak ? std::to_string(static_cast<long>(std::lround(bench::peak_rss_mib()))) + " MiB" : "n/a";
        // A lone pair whose first frame was prepared when it arrived (as the C ABI does): the
        // time left once the second frame is there, and the part done ahead.
        cache.clear();
        std::vector<double> after_first, ahead;
        int prepared_reused = 0;
        for (int r = 0; r < a.runs; ++r) {
            pipeline::StreamCache first;
            const auto t0 = Clock::now();
            estimator.prepare_first(c.input.left0, c.input.right0, c.input.lidar0, first);
            ahead.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
            after_first.push_back(estimator.run(c.input, &first).total_seconds);
            prepared_reused += first.last_reused() && first.last_prepared() ? 1 : 0;
        }
        for (int r = 0; r < a.runs; ++r) {
            const auto t0 = Clock::now();
            base_est = opencv_baseline(c.input);
            base.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
        }
        std::printf("  %-22s %9s %9s\n", "stage", "pair", "stream");
        for (const std::string &n : order)
            std::printf("  %-22s %7.3f s %7.3f s\n", n.c_str(), bench::median(stage[n]), bench::median(stream_stage[n]));
        std::printf("  %-22s %7.3f s   peak RSS %.0f MiB (%.0f MiB before the first run)\n", "total",
                    bench::median(total), rss_pipeline, rss_before);
        std::printf("  %-22s %7.3f s   peak RSS %s (%d of %d frames reused the previous t1)\n",
                    "streaming, per frame", bench::median(stream_total), rss_stream.c_str(), reused, a.runs);
        std::printf("  %-22s %7.3f s   once the second frame is there (%.3f s ahead, at the first; %d of %d "
                    "reused it)\n",
                    "pair, t0 ahead", bench::median(after_first), bench::median(ahead), prepared_reused, a.runs);
        if (fewer > 0)
            std::printf("  %d of %d frames ran on fewer than %d threads: other processes kept CPUs busy "
                        "(adaptive_threads; --set adaptive_threads=0 for a fixed count)\n",
                        fewer, 2 * a.runs, opt.threads);
        print_scores("lidarflow", ours, bench::median(total));
        print_scores("OpenCV SGBM+DIS", eval::evaluate_frame(c.gt, base_est, eo), bench::median(base));
        // The stages other than matching (features, SGM, checks, interpolation, scaling) bound what
        // a faster matcher alone can reach: the streamed frame's sum of their medians.
        double other = 0;
        for (const auto &[name, times] : stream_stage)
            if (name.rfind("matching", 0) != 0) other += bench::median(times);
        const double b = bench::median(base);
        std::printf("  time ratio lidarflow / baseline: %.1fx (streaming %.1fx; its stages other than matching "
                    "%.1fx)\n",
                    bench::median(total) / b, bench::median(stream_total) / b, other / b);
    }
    return 0;
}

// A bad argument or a missing or corrupt frame is an error message and exit status 1, not an
// abort.
int main(int argc, char **argv) {
    try {
        return run_bench(argc, argv);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "bench_pipeline: %s\n", e.what());
        return 1;
    }
}
