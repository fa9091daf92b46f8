// SPDX-License-Identifier: MIT
#include "lidar/paper_protocol.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/error.hpp"
#include "core/maps.hpp"
#include "lidar/grid_sampling.hpp"

namespace lidarflow::lidar {
namespace {

void check_disparity(const DisparityMap &d, const char *what) {
    require(!d.empty(), ErrorCode::InvalidArgument, std::string(what) + " is empty");
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x)
            require(!disparity_valid(d(y, x)) || std::isfinite(d(y, x)), ErrorCode::InvalidArgument,
                    std::string(what) + " holds a non-finite disparity");
}

void check_flow(const FlowField &f, cv::Size size) {
    require(f.u.size() == size && f.v.size() == size && f.valid.size() == size, ErrorCode::SizeMismatch,
            "flow and disparity maps differ in size");
}

bool clearly_nearer(float neighbour, float d) {
    return disparity_valid(neighbour) && neighbour > d + std::max(1.0f, 0.05f * d);
}

}  // namespace

DewarpResult dewarp_to_t1(const DisparityMap &disp1, const FlowField &flow, const DewarpOptions &opt) {
    check_disparity(disp1, "disp1");
    check_flow(flow, disp1.size());
    require(opt.gap_min_nearer >= 1 && opt.gap_min_nearer <= 9, ErrorCode::InvalidArgument,
            "dewarp: gap_min_nearer must be in 1..9");
    const int W = disp1.cols, H = disp1.rows;
    DewarpResult r;
    r.disp = filled(H, W, kInvalidDisparity);
    r.source = filled(H, W, cv::Vec2i(-1, -1));
    for (int y = 0; y < H; ++y) {
        for (int x = 0; x < W; ++x) {
            const float d = disp1(y, x);
            if (!disparity_valid(d) || !flow.valid(y, x)) continue;
            const float u = flow.u(y, x), v = flow.v(y, x);
            require(std::isfinite(u) && std::isfinite(v), ErrorCode::InvalidArgument, "flow holds a non-finite vector");
            ++r.moved;
            const double tx = std::floor(x + static_cast<double>(u) + 0.5);
            const double ty = std::floor(y + static_cast<double>(v) + 0.5);
            if (!(tx >= 0 && ty >= 0 && tx < W && ty < H)) {
                ++r.outside;
                continue;
            }
            const int qx = static_cast<int>(tx), qy = static_cast<int>(ty);
            float &cell = r.disp(qy, qx);
            if (disparity_valid(cell)) {
                ++r.collisions;
                if (d <= cell) continue;  // equal: the first in row-major order stays
            }
            cell = d;
            r.source(qy, qx) = cv::Vec2i(x, y);
        }
    }
    if (opt.gap_min_nearer <= 8) {
        // Decided on the splatted map as a whole, so the result does not depend on scan order.
        const DisparityMap splat = r.disp.clone();
        for (int y = 0; y < H; ++y) {
            for (int x = 0; x < W; ++x) {
                const float d = splat(y, x);
                if (!disparity_valid(d)) continue;
                int nearer = 0;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int nx = x + dx, ny = y + dy;
                        if ((dx || dy) && nx >= 0 && ny >= 0 && nx < W && ny < H && clearly_nearer(splat(ny, nx), d))
                            ++nearer;
                    }
                if (nearer >= opt.gap_min_nearer) {
                    r.disp(y, x) = kInvalidDisparity;
                    r.source(y, x) = cv::Vec2i(-1, -1);
                    ++r.gaps;
                }
            }
        }
    }
    return r;
}

PaperSamples sample_paper_protocol(const DisparityMap &disp0, const DisparityMap &disp1, const FlowField &flow,
                                   const PaperProtocolOptions &opt) {
    check_disparity(disp0, "disp0");
    require(disp1.size() == disp0.size(), ErrorCode::SizeMismatch, "disp0 and disp1 differ in size");
    require(opt.window >= 1 && opt.window % 2 == 1, ErrorCode::InvalidArgument, "paper protocol: window must be odd");
    require(opt.step == 0 || opt.step >= opt.window, ErrorCode::InvalidArgument,
            "paper protocol: step must be 0 (search) or >= the window");
    require(opt.step != 0 || opt.target_points >= 1, ErrorCode::InvalidArgument,
            "paper protocol: target point count must be >= 1");

    PaperSamples out;
    out.dewarp = dewarp_to_t1(disp1, flow, opt.dewarp);
    const int W = disp0.cols, H = disp0.rows, r = opt.window / 2;

    // D0 sample pixels, marked while one step is evaluated and cleared afterwards.
    cv::Mat1b marks = cv::Mat1b::zeros(H, W);
    const cv::Mat2i &source = out.dewarp.source;
    auto far_from_d0 = [&](int x, int y) {
        const cv::Vec2i s = source(y, x);
        for (int sy = std::max(0, s[1] - r); sy <= std::min(H - 1, s[1] + r); ++sy)
            for (int sx = std::max(0, s[0] - r); sx <= std::min(W - 1, s[0] + r); ++sx)
                if (marks(sy, sx)) return false;
        return true;
    };
    auto run = [&](int step, SparseLidar &d0, SparseLidar &d1) {
        d0 = sample_grid(disp0, grid_spec(step, false, opt.window, opt.phase));
        for (const LidarPoint &p : d0.points) marks(p.y, p.x) = 1;
        d1 = sample_grid(out.dewarp.disp, grid_spec(step, true, opt.window, opt.phase), far_from_d0);
        for (const LidarPoint &p : d0.points) marks(p.y, p.x) = 0;
    };

    out.step = opt.step;
    if (out.step == 0) {
        out.step = choose_step(opt.window, std::max({W, H, opt.window}), [&](int step) {
            SparseLidar a, b;
            run(step, a, b);
            return std::labs(static_cast<long>(a.points.size()) - opt.target_points) +
                   std::labs(static_cast<long>(b.points.size()) - opt.target_points);
        });
    }
    run(out.step, out.d0, out.d1);
    for (const LidarPoint &p : out.d1.points) {
        const cv::Vec2i s = source(p.y, p.x);
        out.d1_source.emplace_back(s[0], s[1]);
    }
    return out;
}

cv::Point2d placement_phase(int placement) {
    require(placement >= 0, ErrorCode::InvalidArgument, "paper protocol: placement must be >= 0");
    // The R2 sequence (Roberts 2018): fractional parts of j / rho and j / rho^2, rho the plastic
    // number; its points fill the unit square evenly for any count, so the first P placements
    // are a fair sample of where a grid can fall.
    constexpr double a1 = 0.7548776662466927, a2 = 0.5698402909980532;
    const double j = placement;
    return {j * a1 - std::floor(j * a1), j * a2 - std::floor(j * a2)};
}

}  // namespace lidarflow::lidar
