// SPDX-License-Identifier: MIT
#pragma once
// Runs the estimator over KITTI-layout frames and scores every requested variant against the
// ground truth: the engine of `lidarflow kitti` (the paper's Tables I and II).
#include <functional>
#include <string>
#include <vector>

#include "eval/kitti_eval.hpp"
#include "eval/outlier_regions.hpp"
#include "pipeline/estimator.hpp"

namespace lidarflow::eval {

enum class LidarProtocol { Paper, Velodyne, None };

// "paper" / "velodyne" / "none"; parse throws Error(InvalidArgument).
const char *protocol_name(LidarProtocol p);
LidarProtocol parse_protocol(const std::string &name);

struct LidarInputOptions {
    LidarProtocol protocol = LidarProtocol::Paper;
    int points = 88;  // paper: target per map; velodyne: thin to N (0 = the full scan)
    int beams = 0;    // velodyne only: keep K beams (0 = all)
    int placement = 0;  // paper only: placement of the sampling grids (lidar::placement_phase; 0 = the paper's)
};

// One KITTI frame pair with its sparse LiDAR, as the estimator takes it.
struct KittiFrame {
    std::string id;
    pipeline::FrameInput input;
};

// Loads the four images of `id` and makes the LiDAR inputs by the chosen protocol (paper: from
// the ground truth; velodyne: from the raw scans and calibration, D1 from velodyne/ID_11.bin
// when the layout has it, else empty). Throws Io/Format naming the file that is missing or bad.
KittiFrame load_kitti_frame(const std::string &root, const std::string &id, const LidarInputOptions &lidar);

// One row of a results table: a named variant scored on every frame.
struct ResultRow {
    std::string group;  // "Matching", "Consist. Check", "Interpolation"
    std::string name;   // e.g. "im+LiDAR+win", "Spars+LiDAR & Interp+LiDAR"
    KittiEvaluation evaluation;
};

struct FrameTimings {
    std::string id;
    size_t lidar0_points = 0, lidar1_points = 0;
    std::vector<pipeline::StageTime> stages;  // of the main (non-ablation) run
    double total_seconds = 0;
};

struct KittiRunOptions {
    std::string root;              // KITTI training folder (images, calibration, GT)
    std::vector<std::string> ids;  // frames; empty = every frame in root
    LidarInputOptions lidar;
    pipeline::EstimatorOptions estimator;  // last_stage = what is written; use_lidar from the protocol
    bool ablation = false;         // Table I rows for every stage up to last_stage
    std::string out;               // submission layout + viz + report.json ("" = write nothing)
    bool write_viz = true;
};

struct KittiRunReport {
    std::vector<ResultRow> rows;  // the main result is rows.front() unless ablation
    std::vector<FrameTimings> timings;
    size_t main_row = 0;          // index of the row that was written to out
    // Ablation runs to the final stage: where the final result's SF outliers are, pooled over
    // frames, and the same for the image-only pipeline when the main one uses LiDAR.
    OutlierBreakdown outlier_regions, outlier_regions_image_only;
};

// Progress callback: (frame index, frame count, what is running now).
using Progress = std::function<void(size_t, size_t, const std::string &)>;

// Runs everything; writes OUT/{disp_0,disp_1,flow}/ID_10.png (the main result), OUT/viz/ and
// OUT/report.json when out is set. Frames without ground truth are run but not scored. Ids
// that are not 6 digits (InvalidArgument) and an output folder that cannot be written (Io)
// fail before the first frame.
KittiRunReport run_kitti(const KittiRunOptions &options, const Progress &progress = {});

// Table I style text: per row the per-frame mean of EPE / outliers / density (occ), then
// per-frame SF outliers, then Table II for rows that have LiDAR seeds.
std::string format_report(const KittiRunReport &report);
std::string report_json(const KittiRunOptions &options, const KittiRunReport &report);

}  // namespace lidarflow::eval
