// SPDX-License-Identifier: MIT
#include "lidar/grid_sampling.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.hpp"

namespace lidarflow::lidar {

GridSpec grid_spec(int step, bool half_shift, int window, cv::Point2d phase) {
    require(step >= 1, ErrorCode::InvalidArgument, "grid step must be >= 1");
    const auto fraction = [](double v) { return std::isfinite(v) && v >= 0.0 && v < 1.0; };
    require(fraction(phase.x) && fraction(phase.y), ErrorCode::InvalidArgument,
            "grid phase must lie in [0, 1) of the step");
    GridSpec g;
    g.step = step;
    g.window = window;
    const int o = step / 2;
    const int off = half_shift ? (o + step / 2) % step : o;
    const auto moved = [&](double p) { return (off + static_cast<int>(std::lround(p * step))) % step; };
    g.offset = cv::Point(moved(phase.x), moved(phase.y));
    return g;
}

SparseLidar sample_grid(const DisparityMap &dense, const GridSpec &grid, const std::function<bool(int, int)> &accept) {
    require(!dense.empty(), ErrorCode::InvalidArgument, "sample_grid: empty disparity map");
    require(grid.window >= 1 && grid.window % 2 == 1, ErrorCode::InvalidArgument,
            "sample_grid: window must be odd and >= 1");
    require(grid.step >= grid.window, ErrorCode::InvalidArgument,
            "sample_grid: step " + std::to_string(grid.step) + " is smaller than the window");
    require(grid.offset.x >= 0 && grid.offset.y >= 0 && grid.offset.x < grid.step && grid.offset.y < grid.step,
            ErrorCode::InvalidArgument, "sample_grid: offset must lie in [0, step)");

    // Window offsets sorted by distance to the centre, ties in row-major order.
    const int r = grid.window / 2;
    std::vector<cv::Point> order;
    for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) order.emplace_back(dx, dy);
    std::stable_sort(order.begin(), order.end(), [](const cv::Point &a, const cv::Point &b) {
        return a.x * a.x + a.y * a.y < b.x * b.x + b.y * b.y;
    });

    SparseLidar out;
    out.width = dense.cols;
    out.height = dense.rows;
    for (int cy = grid.offset.y; cy < dense.rows; cy += grid.step) {
        for (int cx = grid.offset.x; cx < dense.cols; cx += grid.step) {
            for (const cv::Point &o : order) {
                const int x = cx + o.x, y = cy + o.y;
                if (x < 0 || y < 0 || x >= dense.cols || y >= dense.rows) continue;
                const float d = dense(y, x);
                if (!disparity_valid(d) || (accept && !accept(x, y))) continue;
                out.points.push_back({x, y, d});
                break;
            }
        }
    }
    return out;
}

int choose_step(int min_step, int max_step, const std::function<long(int)> &cost) {
    require(min_step >= 1 && max_step >= min_step, ErrorCode::InvalidArgument, "choose_step: empty step range");
    int best = min_step;
    long best_err = -1;
    for (int s = min_step; s <= max_step; ++s) {
        const long err = cost(s);
        if (best_err < 0 || err < best_err) {
            best = s;
            best_err = err;
        }
    }
    return best;
}

}  // namespace lidarflow::lidar
