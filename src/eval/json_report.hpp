// SPDX-License-Identifier: MIT
#pragma once
// Results of an evaluation as JSON (nlohmann-json, keys in the order below). Layout:
//   { "format": "lidarflow-eval/1", "mode": "filled"|"est-only", "window": 15,
//     "frames": [FRAME...], "pooled": FRAME, "mean_over_frames": MEANS }
//   FRAME = { "id", "dense": REGION, "lidar": { "n_seeds", "seeds": REGION, "window": REGION,
//             "window_excl_seeds": REGION } (only with a LiDAR seed map) }
//   REGION = { "occ": COMPONENTS, "noc": COMPONENTS (when the noc GT was given) }
//   COMPONENTS = { "d0"|"d1"|"fl"|"sf": { "outlier_pct", "epe" (not for sf), "density_pct",
//                  "n_err", "n_total", "n_est", "n_gt" } }
// "pooled" sums counts over frames (the devkit's figure); "mean_over_frames" averages per-frame
// percentages. Undefined values (nothing to score) are written as null.
#include <string>

#include "eval/kitti_eval.hpp"
#include "eval/outlier_regions.hpp"

namespace lidarflow::eval {

std::string to_json(const KittiEvaluation &ev);

// Writes to_json(ev) to path (creating parent folders). Io on failure.
void write_json(const std::string &path, const KittiEvaluation &ev);

const char *mode_name(FillMode mode);  // "filled" / "est-only"

// An outlier breakdown as a JSON array: [{ "family", "region", "occ": COMPONENTS }, ...]
// (Filled-mode counts over the region's pixels).
std::string to_json(const OutlierBreakdown &b);

}  // namespace lidarflow::eval
