// SPDX-License-Identifier: MIT
#include "lidar/velodyne_protocol.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/error.hpp"
#include "lidar/grid_sampling.hpp"

namespace lidarflow::lidar {

std::vector<int> ring_indices(const std::vector<io::VelodynePoint> &points) {
    require(!points.empty(), ErrorCode::InvalidArgument, "ring_indices: empty scan");
    std::vector<int> ring(points.size());
    int r = 0;
    double prev = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double az = std::atan2(static_cast<double>(points[i].y), static_cast<double>(points[i].x));
        // One turn sweeps azimuth continuously; only the start of the next laser jumps by ~2 pi.
        if (i > 0 && std::fabs(az - prev) > M_PI) ++r;
        prev = az;
        ring[i] = r;
    }
    const int rings = r + 1;
    require(rings >= 32 && rings <= 128, ErrorCode::Format,
            "Velodyne scan is not stored ring by ring (" + std::to_string(rings) +
                " azimuth turns): cannot thin it by beams");
    return ring;
}

std::vector<io::VelodynePoint> keep_beams(const std::vector<io::VelodynePoint> &points, int beams) {
    const std::vector<int> ring = ring_indices(points);
    const int rings = ring.back() + 1;
    require(beams >= 1 && beams <= rings, ErrorCode::InvalidArgument,
            "keep_beams: beams must be in 1.." + std::to_string(rings) + ", got " + std::to_string(beams));
    std::vector<char> keep(static_cast<std::size_t>(rings), 0);
    for (int j = 0; j < beams; ++j) keep[static_cast<std::size_t>((2 * j + 1) * rings / (2 * beams))] = 1;
    std::vector<io::VelodynePoint> out;
    for (std::size_t i = 0; i < points.size(); ++i)
        if (keep[static_cast<std::size_t>(ring[i])]) out.push_back(points[i]);
    return out;
}

VelodyneSamples sample_velodyne_protocol(const io::VelodyneScan &scan, const io::CamToCamCalib &calib,
                                         const cv::Matx44d &velo_to_cam, cv::Size image,
                                         const VelodyneProtocolOptions &opt) {
    require(opt.target_points >= 0 && opt.beams >= 0, ErrorCode::InvalidArgument,
            "velodyne protocol: point and beam counts must be >= 0");
    require(opt.window >= 1 && opt.window % 2 == 1, ErrorCode::InvalidArgument, "velodyne protocol: window must be odd");
    require(opt.step == 0 || opt.step >= opt.window, ErrorCode::InvalidArgument,
            "velodyne protocol: step must be 0 (search) or >= the window");

    VelodyneSamples out;
    const SparseLidar all = opt.beams > 0
                                ? project_to_left(keep_beams(scan.points, opt.beams), calib, velo_to_cam, image, opt.projection)
                                : project_to_left(scan.points, calib, velo_to_cam, image, opt.projection);
    out.projected = all.points.size();
    out.d1.width = out.d0.width = image.width;
    out.d1.height = out.d0.height = image.height;
    if (opt.target_points == 0 && opt.step == 0) {
        out.d0 = all;
        return out;
    }
    const DisparityMap dense = all.to_map();
    out.step = opt.step;
    if (out.step == 0) {
        out.step = choose_step(opt.window, std::max({image.width, image.height, opt.window}), [&](int step) {
            const long n = static_cast<long>(sample_grid(dense, grid_spec(step, false, opt.window)).points.size());
            return std::labs(n - opt.target_points);
        });
    }
    out.d0 = sample_grid(dense, grid_spec(out.step, false, opt.window));
    return out;
}

}  // namespace lidarflow::lidar
