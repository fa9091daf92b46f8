// SPDX-License-Identifier: MIT
#pragma once
// Human-readable tables of an evaluation: per frame and summary rows, occ and noc, outliers [%],
// EPE [px] and density [%]; and the paper's Table II (SF outliers at LiDAR seeds / in the
// support windows / dense) when a seed map was used.
#include <string>

#include "eval/kitti_eval.hpp"

namespace lidarflow::eval {

std::string format_tables(const KittiEvaluation &ev);

}  // namespace lidarflow::eval
