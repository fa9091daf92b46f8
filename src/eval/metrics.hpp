// SPDX-License-Identifier: MIT
#pragma once
// KITTI Scene Flow 2015 scores of one estimate against ground truth, counted as the official
// devkit (evaluate_scene_flow.cpp) counts them, plus the paper's views of the same numbers:
//  - outlier: |error| > 3 px AND |error| > 5 % of the ground-truth magnitude (disparity value,
//    or flow vector length); the disparity error is |d_gt - d_est|, the flow error the
//    end-point distance;
//  - SF outlier: counted where the d0, d1 and flow ground truths are all valid; a pixel is an
//    outlier if its D0, D1 or Fl is;
//  - density: share of ground-truth pixels whose *unfilled* estimate is valid (for SF the devkit
//    looks at the d0 estimate only);
//  - two modes: Filled (the devkit: holes filled by background interpolation, every GT pixel is
//    scored) and EstimateOnly (only GT pixels with a valid estimate are scored: the paper's
//    Table I for the sparse stages; for SF all three estimates must be valid there);
//  - the paper's Table II: the same scores restricted to the LiDAR seed pixels, to the square
//    support windows around them, and to the whole image.
// Scores are exact for the values given; a submission read from PNG files is quantised by the
// codec first (1/256 px disparity, 1/64 px flow), as the devkit sees it.
#include <cstdint>
#include <string>
#include <vector>

#include "core/maps.hpp"

namespace lidarflow::eval {

enum class FillMode {
    Filled,        // devkit: fill holes, then score every ground-truth pixel
    EstimateOnly,  // score only ground-truth pixels where the estimate is valid
};

// Ground truth of one frame for one pixel set (KITTI's occ = all, or noc = non-occluded).
struct GroundTruth {
    DisparityMap d0, d1;  // d1 warped into the t0 left frame, as KITTI's disp_occ_1
    FlowField flow;
};

struct FrameGroundTruth {
    GroundTruth occ;
    bool has_noc = false;
    GroundTruth noc;  // used when has_noc
};

// An estimate with holes allowed: disparity < 0 and flow valid = 0 mark them.
struct Estimate {
    DisparityMap d0, d1;
    FlowField flow;
};

// Splits a scene flow field into the three KITTI maps (the caller keeps the field). A pixel is
// a hole where valid = 0; where valid = 1 a negative d0 or d1 is a hole of that map only.
// Throws InvalidArgument on NaN/inf at a valid pixel, SizeMismatch on planes of different sizes.
Estimate estimate_from_scene_flow(const SceneFlowField &sf);

// Counts of one component over one pixel set, additive over frames.
struct Counts {
    int64_t n_gt = 0;      // ground-truth pixels (SF: d0, d1 and flow GT all valid)
    int64_t n_est = 0;     // of those, with a valid unfilled estimate (devkit density numerator)
    int64_t n_total = 0;   // pixels scored: n_gt when Filled, valid-estimate ones otherwise
    int64_t n_err = 0;     // outliers among the scored pixels
    double abs_err_sum = 0;  // sum of |disparity error| or flow end-point error; 0 for SF

    // Percentages / means; NaN when the denominator is 0 (nothing to score).
    double outlier_pct() const;
    double epe() const;  // abs_err_sum / n_total; meaningless for SF (not reported)
    double density_pct() const;

    Counts &operator+=(const Counts &o);
};

struct ComponentScores {
    Counts d0, d1, fl, sf;

    ComponentScores &operator+=(const ComponentScores &o);
};

// One image region, scored against the occ and (when given) the noc ground truth.
struct RegionScores {
    ComponentScores occ;
    bool has_noc = false;
    ComponentScores noc;
};

struct EvalOptions {
    FillMode mode = FillMode::Filled;
    int window = 15;  // side of the square support window around each LiDAR seed (odd, >= 1)
};

struct FrameScore {
    std::string id;
    RegionScores dense;  // every pixel
    // Table II, only when a LiDAR seed map was given:
    bool has_lidar = false;
    int64_t n_seeds = 0;
    RegionScores seeds;              // the seed pixels themselves
    RegionScores window;             // union of the windows around seeds, seeds included
    RegionScores window_excl_seeds;  // the same windows without the seed pixels
};

// Scores one frame. lidar_seeds (may be null) is the D_l^0 map used by the estimator: its valid
// pixels are the seeds. Inputs are only read. Throws SizeMismatch when any map differs in size
// from occ.d0 (or a flow's planes differ), InvalidArgument on empty maps, NaN/inf anywhere in a
// disparity map or at a valid flow pixel, or an even / non-positive window.
FrameScore evaluate_frame(const FrameGroundTruth &gt, const Estimate &est, const EvalOptions &opt,
                          const DisparityMap *lidar_seeds = nullptr, const std::string &id = "");
FrameScore evaluate_frame(const FrameGroundTruth &gt, const SceneFlowField &est, const EvalOptions &opt,
                          const DisparityMap *lidar_seeds = nullptr, const std::string &id = "");

// Scores of one estimate on each of several pixel sets (masks: nonzero = in the set, each the
// size of gt.d0), against one ground truth; the estimate is filled once (Filled mode). Inputs
// are only read. Throws as evaluate_frame, and SizeMismatch for a mask of another size.
std::vector<ComponentScores> evaluate_masks(const GroundTruth &gt, const Estimate &est, FillMode mode,
                                            const std::vector<cv::Mat1b> &masks);

// Mean over frames of a per-frame percentage / EPE; frames where it is undefined are skipped.
struct MeanStat {
    double outlier_pct = 0, epe = 0;  // over frames with scored pixels (NaN when none)
    double density_pct = 0;           // over frames with ground truth (NaN when none)
    int frames_scored = 0, frames_with_gt = 0;
};
struct ComponentMeans {
    MeanStat d0, d1, fl, sf;
};
struct RegionMeans {
    ComponentMeans occ;
    bool has_noc = false;
    ComponentMeans noc;
};

// Two ways to summarise frames, kept side by side because they differ:
//  - pooled: counts summed over all frames, then divided (what the devkit reports);
//  - mean:   per-frame percentages / EPEs averaged with equal weight per frame.
// noc / Table II parts are summarised only when every frame has them.
struct Summary {
    FrameScore pooled;  // id "pooled"
    RegionMeans mean_dense, mean_seeds, mean_window, mean_window_excl_seeds;
};

// Throws InvalidArgument when frames is empty.
Summary summarize(const std::vector<FrameScore> &frames);

// The outlier rule itself (exposed for tests and for per-pixel error maps).
bool disparity_outlier(float gt, float est);
bool flow_outlier(float gt_u, float gt_v, float est_u, float est_v);

}  // namespace lidarflow::eval
