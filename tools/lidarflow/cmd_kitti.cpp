// SPDX-License-Identifier: MIT
// lidarflow kitti: the estimator over KITTI-layout frames with the chosen sparse-LiDAR
// protocol, scored against the ground truth (the paper's Tables I and II with --ablation).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "args.hpp"
#include "commands.hpp"
#include "log.hpp"
#include "rig_args.hpp"
#include "core/error.hpp"
#include "eval/kitti_runner.hpp"
#include "eval/metrics.hpp"
#include "pipeline/option_assignments.hpp"

namespace lidarflow::cli {
namespace {

// Per row and frame: mean (+- standard error of the mean) of the occ outlier rates over the
// runs, which differ in their random seeds and, with --placements, in where the paper
// protocol's sampling grids fall.
std::string format_seed_summary(const std::vector<eval::KittiRunReport> &runs, int seeds, int placements) {
    std::string out;
    char line[256];
    if (placements == 1)
        std::snprintf(line, sizeof line, "Over %d seeds: outliers [%%] (occ), mean +- standard error of the mean\n",
                      seeds);
    else
        std::snprintf(line, sizeof line,
                      "Over %d seed(s) x %d LiDAR placements: outliers [%%] (occ), mean +- standard error of the "
                      "mean\n",
                      seeds, placements);
    out += line;
    std::snprintf(line, sizeof line, "%-52s %-8s %15s %15s %15s %15s\n", "variant", "frame", "D0", "D1", "Fl", "SF");
    out += line;
    const auto &rows = runs.front().rows;
    for (size_t r = 0; r < rows.size(); ++r) {
        const auto &frames = rows[r].evaluation.frames;
        for (size_t f = 0; f < frames.size(); ++f) {
            std::snprintf(line, sizeof line, "%-52s %-8s", (rows[r].group + ": " + rows[r].name).substr(0, 52).c_str(),
                          frames[f].id.c_str());
            out += line;
            for (int c = 0; c < 4; ++c) {
                std::vector<double> v;
                for (const auto &run : runs) {
                    const eval::ComponentScores &s = run.rows[r].evaluation.frames[f].dense.occ;
                    const eval::Counts *parts[4] = {&s.d0, &s.d1, &s.fl, &s.sf};
                    v.push_back(parts[c]->outlier_pct());
                }
                double mean = 0, var = 0;
                for (double x : v) mean += x / v.size();
                for (double x : v) var += (x - mean) * (x - mean) / (v.size() - 1);
                std::snprintf(line, sizeof line, " %8.2f +-%4.2f", mean, std::sqrt(var / v.size()));
                out += line;
            }
            out += "\n";
        }
    }
    return out;
}

int run_kitti_command(int argc, char **argv) {
    // One rig for every frame would score against ground truth of other cameras.
    refuse_rig_options(argc, argv, "kitti",
                       "each KITTI frame has its own calibration (calib_cam_to_cam/ID.txt, calib_velo_to_cam/ID.txt) "
                       "and its ground truth is in that frame's rectified camera; for your own rig use `lidarflow run "
                       "--calib` or `lidarflow sequence --calib`");
    Args args("kitti", argc, argv,
              {{"root", true, "DIR  KITTI training folder (image_2, image_3, disp_occ_*, flow_occ, velodyne; each frame's calibration from calib_cam_to_cam/ and calib_velo_to_cam/, no --calib)"},
               {"ids", true, "A,B  frames (default: every image_2/*_10.png)"},
               {"lidar", true, "P    sparse LiDAR protocol: paper (default) | velodyne (t1: velodyne/ID_11.bin if present) | none"},
               {"points", true, "N    LiDAR points per map (paper: default 88; velodyne: thin to N, 0 = full scan)"},
               {"beams", true, "K    velodyne: keep K beams (default all)"},
               {"placements", true, "P    paper: also score P - 1 other placements of the sampling grids per seed (default 1: the paper's only)"},
               {"stage", true, "S    stop after matching|consistency|sparse|interpolation (default)"},
               {"ablation", false, "run and score every variant of Table I (and Table II); preset paper unless --preset says"},
               {"threads", true, "N    OpenMP threads (default: every usable CPU, fewer while others are busy)"},
               {"preset", true, "NAME speed/accuracy preset: default | paper | balanced | fast | realtime"},
               {"set", true, "K=V,.. any option key of the C ABI (lidarflow.h), after the preset"},
               {"scale", true, "S    processing scale in [0.125, 1] (default: the preset's)"},
               {"seed", true, "N    random seed of the matcher and the interpolation (default 1)"},
               {"seeds", true, "K    run seeds N .. N+K-1 and print per-frame means (+- standard error)"},
               {"out", true, "DIR  write disp_0/, disp_1/, flow/, viz/ and report.json here"},
               {"no-viz", false, "do not write pictures"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    eval::KittiRunOptions o;
    o.root = args.required("root");
    o.ids = args.list("ids");
    o.lidar.protocol = eval::parse_protocol(args.str("lidar", "paper"));
    const bool velodyne = o.lidar.protocol == eval::LidarProtocol::Velodyne;
    o.lidar.points = args.integer("points", velodyne ? 0 : 88);
    o.lidar.beams = args.integer("beams", 0);
    require(o.lidar.points >= 0 && o.lidar.beams >= 0, ErrorCode::InvalidArgument,
            "kitti: --points and --beams must be >= 0");
    require(o.lidar.protocol == eval::LidarProtocol::Paper ? o.lidar.points > 0 : true,
            ErrorCode::InvalidArgument, "kitti: --points must be > 0 for the paper protocol");
    // Table I's rows are the paper's matcher variants: --ablation runs the paper's design
    // unless a preset is named.
    const std::string preset = args.str("preset", args.flag("ablation") ? "paper" : "default");
    o.estimator = pipeline::EstimatorOptions::preset(preset);
    o.estimator.last_stage = pipeline::parse_stage(args.str("stage", "interpolation"));
    o.estimator.threads = args.integer("threads", o.estimator.threads);
    if (args.has("scale")) o.estimator.processing_scale = args.number("scale", 1.0);
    if (args.has("seed")) {
        const int seed = args.integer("seed", 1);
        require(seed >= 0, ErrorCode::InvalidArgument, "kitti: --seed must be >= 0");
        o.estimator.matching.random_seed = static_cast<uint64_t>(seed);
        o.estimator.interpolation.random_seed = static_cast<unsigned>(seed);
    }
    pipeline::apply_option_assignments(o.estimator, args.list("set"));
    o.ablation = args.flag("ablation");
    o.out = args.str("out", "");
    o.write_viz = !args.flag("no-viz");

    const int seeds = args.integer("seeds", 1);
    require(seeds >= 1 && seeds <= 1000, ErrorCode::InvalidArgument, "kitti: --seeds must be in [1, 1000]");
    const int placements = args.integer("placements", 1);
    require(placements >= 1 && placements <= 1000, ErrorCode::InvalidArgument,
            "kitti: --placements must be in [1, 1000]");
    require(placements == 1 || o.lidar.protocol == eval::LidarProtocol::Paper, ErrorCode::InvalidArgument,
            "kitti: --placements needs the paper protocol (a real scan has no grid to move)");

    // Each line has the time elapsed and, once a frame is done, the time left (frames of every
    // seed and placement together); piped, one line per step.
    Progress bar(verbosity() != Verbosity::Quiet, isatty(fileno(stderr)) != 0, 0.0);
    const size_t runs = static_cast<size_t>(seeds) * static_cast<size_t>(placements);
    size_t run_index = 0;
    const Progress &clock = bar;
    double step_start = 0;
    std::string step;
    const auto progress = [&](size_t i, size_t n, const std::string &what) {
        inputs_begin();  // run_kitti checked the ids, the output folder and the options first
        const double now = clock.seconds();
        if (!step.empty()) detail("kitti:   %s took %s\n", step.c_str(), format_duration(now - step_start).c_str());
        step = what;
        step_start = now;
        const size_t done = run_index * n + i, total = runs * n;
        const std::string counter = runs > 1 ? "[run " + std::to_string(run_index + 1) + "/" + std::to_string(runs) + ", " : "[";
        bar.update(static_cast<double>(done), static_cast<double>(total),
                   counter + std::to_string(i + 1) + "/" + std::to_string(n) + "] " + what);
    };
    const auto finish_run = [&]() {
        if (!step.empty()) detail("kitti:   %s took %s\n", step.c_str(), format_duration(clock.seconds() - step_start).c_str());
        step.clear();
        ++run_index;
    };
    detail("kitti: LiDAR %s, preset %s, %d thread(s), up to stage %s, %d seed(s) x %d placement(s)\n",
           eval::protocol_name(o.lidar.protocol), preset.c_str(), o.estimator.threads,
           pipeline::stage_name(o.estimator.last_stage), seeds, placements);
    const eval::KittiRunReport rep = eval::run_kitti(o, progress);
    finish_run();
    // Further seeds and placements: scored only (the first seed's run at the paper's placement
    // is the one written to --out).
    std::vector<eval::KittiRunReport> more;
    for (int k = 0; k < seeds; ++k)
        for (int j = 0; j < placements; ++j) {
            if (k == 0 && j == 0) continue;
            eval::KittiRunOptions ok = o;
            ok.out.clear();
            ok.lidar.placement = j;
            ok.estimator.matching.random_seed = o.estimator.matching.random_seed + static_cast<uint64_t>(k);
            ok.estimator.interpolation.random_seed = o.estimator.interpolation.random_seed + static_cast<unsigned>(k);
            more.push_back(eval::run_kitti(ok, progress));
            finish_run();
        }
    bar.finish();
    note("kitti: done in %s\n", format_duration(clock.seconds()).c_str());

    std::printf("lidarflow kitti: %zu frame(s), LiDAR %s, stage %s, %d thread(s)\n", rep.timings.size(),
                eval::protocol_name(o.lidar.protocol), pipeline::stage_name(o.estimator.last_stage),
                o.estimator.threads);
    for (const eval::FrameTimings &t : rep.timings) {
        std::printf("  %s  LiDAR %zu + %zu points  %.2f s (", t.id.c_str(), t.lidar0_points, t.lidar1_points,
                    t.total_seconds);
        for (size_t j = 0; j < t.stages.size(); ++j)
            std::printf("%s%s %.2f", j ? ", " : "", t.stages[j].name.c_str(), t.stages[j].seconds);
        std::printf(")\n");
    }
    if (velodyne) {
        std::string without_t1;
        for (const eval::FrameTimings &t : rep.timings)
            if (t.lidar1_points == 0) without_t1 += (without_t1.empty() ? "" : ", ") + t.id;
        if (!without_t1.empty())
            std::printf("  no scan at t1 (velodyne/ID_11.bin) for %s: D1 is empty there, the estimator uses the t0 "
                        "scan only\n",
                        without_t1.c_str());
    }
    std::printf("\n%s", eval::format_report(rep).c_str());
    if (!more.empty()) {
        std::vector<eval::KittiRunReport> all{rep};
        all.insert(all.end(), more.begin(), more.end());
        std::printf("\n%s", format_seed_summary(all, seeds, placements).c_str());
    }
    if (!o.out.empty()) std::printf("\nwrote %s/{disp_0,disp_1,flow,viz}/ and %s/report.json\n", o.out.c_str(), o.out.c_str());
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(kitti, "kitti", "run the estimator on KITTI frames and score it (Tables I and II)",
                  run_kitti_command, 60);

}  // namespace lidarflow::cli
