// SPDX-License-Identifier: MIT
#pragma once
// Scoring of a KITTI-style submission folder (disp_0/, disp_1/, flow/ with NNNNNN_10.png)
// against the ground truth of a KITTI Scene Flow 2015 training folder.
#include <string>
#include <vector>

#include "eval/metrics.hpp"

namespace lidarflow::eval {

// Reads disp_occ_0/1 and flow_occ of one frame, and the noc maps when all three exist (has_noc).
// Throws Io naming a missing/unreadable occ file (or a missing noc file when only some exist),
// Format on a malformed PNG.
FrameGroundTruth load_ground_truth(const std::string &kitti_root, const std::string &id);

// Reads disp_0/, disp_1/ and flow/ of one frame from a submission folder. Throws Io naming the
// missing file, Format on a malformed PNG.
Estimate load_estimate(const std::string &est_root, const std::string &id);

// The D_l^0 seed map lidar_0/ID_10.png under lidar_root. Io when missing.
DisparityMap load_lidar_seeds(const std::string &lidar_root, const std::string &id);

// Ids of every disp_0/NNNNNN_10.png in a submission folder, sorted. Io when disp_0/ is missing.
std::vector<std::string> submission_ids(const std::string &est_root);

struct KittiEvaluation {
    EvalOptions options;
    std::vector<FrameScore> frames;
    Summary summary;
};

// Loads and scores each id (lidar_root may be empty: no Table II). Throws as the loaders and
// evaluate_frame do; InvalidArgument when ids is empty.
KittiEvaluation evaluate_kitti(const std::string &kitti_root, const std::string &est_root,
                               const std::vector<std::string> &ids, const EvalOptions &opt,
                               const std::string &lidar_root = "");

}  // namespace lidarflow::eval
