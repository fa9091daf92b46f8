// SPDX-License-Identifier: MIT
#pragma once
// Sparse LiDAR input from the real Velodyne scan (KITTI has one scan per frame, at t0): the scan
// projected into I_l^0 (lidar/projection.hpp), optionally thinned
//  - to K beams: keep K evenly spaced lasers out of the scan's rings, to mimic a sensor with
//    fewer beams (applied before projection);
//  - to about N points: the paper's 5x5-window grid sampler (lidar/grid_sampling.hpp), with the
//    step searched per frame so that the count is closest to N (ties: the smaller step).
// D1 is empty in this protocol: there is no scan at t1.
//
// Beam index. The HDL-64E elevation angle does not identify the laser on KITTI: measured on the
// shared frames, each laser's elevations spread over ~0.7 deg (the sensor is not mounted level)
// while the upper lasers are 1/3 deg apart, and the nearest nominal HDL-64E angle picks the right
// laser for only ~5 % of points. KITTI's .bin files, however, store the scan laser by laser, each
// laser a full turn from azimuth -180 to +180 deg; so the ring index is the number of +-180 deg
// azimuth wrap-arounds before a point (the first and last rings may be partial turns). A scan
// that does not show 32..128 rings this way is not ring-ordered and cannot be thinned by beams.
#include <vector>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"
#include "io/calib.hpp"
#include "io/velodyne.hpp"
#include "lidar/projection.hpp"

namespace lidarflow::lidar {

// Ring index of every point (same order as `points`), from the azimuth wrap-arounds of the scan
// order. Throws Error(Format) when the scan does not look ring-ordered (fewer than 32 or more
// than 128 rings), Error(InvalidArgument) when points is empty.
std::vector<int> ring_indices(const std::vector<io::VelodynePoint> &points);

// The points of `beams` evenly spaced rings (ring floor((j + 0.5) * R / beams), j < beams, of R
// rings). Returns a copy in scan order. Throws Error(InvalidArgument) when beams < 1 or beams > R,
// plus the errors of ring_indices.
std::vector<io::VelodynePoint> keep_beams(const std::vector<io::VelodynePoint> &points, int beams);

struct VelodyneProtocolOptions {
    int target_points = 0;  // N; 0 = keep every projected point
    int beams = 0;          // K; 0 = every beam
    int step = 0;           // fixed grid step (>= window) instead of the search; needs no N
    int window = 5;
    ProjectionOptions projection;
};

struct VelodyneSamples {
    SparseLidar d0;          // in I_l^0
    SparseLidar d1;          // empty point list (no scan at t1), same image size
    std::size_t projected = 0;  // points in the image after beam thinning, before grid thinning
    int step = 0;               // grid step used; 0 when not grid-thinned
};

// Runs the protocol on one scan. The result owns its points. Throws Error(InvalidArgument) for
// target_points < 0, beams < 0, 0 < step < window, or an even window, plus the errors of
// keep_beams and project_to_left.
VelodyneSamples sample_velodyne_protocol(const io::VelodyneScan &scan, const io::CamToCamCalib &calib,
                                         const cv::Matx44d &velo_to_cam, cv::Size image,
                                         const VelodyneProtocolOptions &opt = {});

}  // namespace lidarflow::lidar
