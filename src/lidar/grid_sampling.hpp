// SPDX-License-Identifier: MIT
#pragma once
// Dense-to-sparse sampling of the paper (section "LiDAR-Flow Input Data"): a w x w window
// (w = 5) is moved in regular steps over the image, and inside each window the measurement
// nearest to the window's centre pixel is kept (none when the window holds no measurement).
//
// Window centres lie at (offset.x + i * step, offset.y + j * step) for i, j >= 0 inside the
// image; windows are clipped at the border. step >= w, so windows never overlap and no pixel
// is picked twice. Ties in distance go to the first pixel in row-major order inside the
// window, so results are deterministic.
#include <functional>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"

namespace lidarflow::lidar {

struct GridSpec {
    int step = 0;         // distance between window centres [px], >= window
    cv::Point offset;     // first centre; 0 <= offset.x, offset.y < step
    int window = 5;       // odd window side [px]
};

// The usual origin: centres in the middle of step x step cells (offset step/2), or, with
// half_shift, shifted by a further half step (the cell corners of the unshifted grid); phase
// moves either by a further round(phase * step) px per axis (modulo the step), so grids built
// with the same step and phase keep their stagger. Throws Error(InvalidArgument) for step < 1 or
// a phase outside [0, 1).
GridSpec grid_spec(int step, bool half_shift, int window = 5, cv::Point2d phase = {0, 0});

// Keeps per window the valid pixel of `dense` nearest to the centre for which accept(x, y) is
// true (accept empty: all valid pixels). The result owns its points, one per non-empty window,
// in window row-major order. Throws Error(InvalidArgument) for an empty map, an even or
// non-positive window, step < window, or an offset outside [0, step).
SparseLidar sample_grid(const DisparityMap &dense, const GridSpec &grid,
                        const std::function<bool(int x, int y)> &accept = {});

// The step in [min_step, max_step] with the smallest cost(step), e.g. |count(step) - N|; ties go
// to the smaller step. cost is called once per step. Throws Error(InvalidArgument) when
// min_step < 1 or max_step < min_step.
int choose_step(int min_step, int max_step, const std::function<long(int step)> &cost);

}  // namespace lidarflow::lidar
