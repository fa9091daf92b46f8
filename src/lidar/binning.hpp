// SPDX-License-Identifier: MIT
#pragma once
// Thinning of a dense scan for the stages whose cost grows with the number of points (the
// consistency check keeps every LiDAR pixel, stage 4 anchors and scores on them): at most one
// point per cell x cell square of the image, so a 64-beam scan costs them about what a sparse
// one does, while stage 1's guided stereo still reads every point.
#include "core/lidar.hpp"

namespace lidarflow::lidar {

// Keeps per cell (squares of `cell` px from the image origin) the point nearest the cell's
// centre; ties go to the larger disparity (the nearer surface), then to the earlier point, so
// the result does not depend on the input order except for exact duplicates. cell <= 1 returns
// the input unchanged. Points keep their input order. Does not throw on validated input.
SparseLidar bin_points(const SparseLidar &lidar, int cell);

}  // namespace lidarflow::lidar
