// SPDX-License-Identifier: MIT
#pragma once
// Projection of 3-D LiDAR points into the left rectified image (KITTI camera 2) as a
// SparseLidar, following the KITTI devkit chain:
//   X_rect = R_rect_00 * Tr_velo_to_cam * X_velo,   (u, v, w) = P_rect_02 * X_rect,
//   pixel = (round(u / w), round(v / w)),           d = fx * B / w.
// w is the point's depth in camera 2's rectified frame (P_rect_02's third row is (0 0 1 t_z)),
// so d is the disparity of the left/right pair that P_rect_02 / P_rect_03 describe.
// Only points with w > min_depth and d <= kMaxLidarDisparity (core/limits.hpp) that land inside
// the image are kept; where several land on one pixel the nearest (largest disparity) wins, as
// a LiDAR beam would be blocked by it.
#include <vector>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"
#include "io/calib.hpp"
#include "io/velodyne.hpp"

namespace lidarflow::lidar {

// The pixel of image coordinates (x, y) (pixel centres at integers): the nearest one, as the
// KITTI devkit rounds (floor(x + 0.5)); false when that pixel lies outside the image or x, y
// are not finite. Every LiDAR kind goes through it, so all drop the same points.
bool nearest_pixel(double x, double y, cv::Size image, int &px, int &py);

// LiDAR entries a conversion saw, and those it dropped by reason.
struct DroppedPoints {
    size_t seen = 0;
    size_t behind = 0;     // z <= min_depth
    size_t outside = 0;    // nearest pixel off the image (nearest_pixel)
    size_t too_close = 0;  // disparity above kMaxLidarDisparity
};

// Says in the log how many LiDAR entries a conversion dropped and why (a wrong calibration or
// image size shows this way), naming the reasons that occurred: Info, or Warning when none is
// left (`kept` pixels keep a point). Nothing when none was dropped.
void report_dropped_points(const DroppedPoints &d, double min_depth, cv::Size image, size_t kept);

struct ProjectionOptions {
    double min_depth = 0.1;  // [m] in camera 2's rectified frame; also keeps d finite
};

// Velodyne points (Velodyne frame) -> left image of size `image`. The result owns its points,
// in row-major pixel order. Throws Error(InvalidArgument) for an empty image size, a calibration
// without a valid camera, min_depth <= 0, or a non-finite point.
SparseLidar project_to_left(const std::vector<io::VelodynePoint> &points, const io::CamToCamCalib &calib,
                            const cv::Matx44d &velo_to_cam, cv::Size image, const ProjectionOptions &opt = {});

// Points already in camera 0's rectified frame (X_rect above; for calib_from_camera() this is
// the left camera's frame) -> left image. Same ownership and errors as above.
SparseLidar project_to_left(const std::vector<cv::Point3d> &rect_points, const io::CamToCamCalib &calib,
                            cv::Size image, const ProjectionOptions &opt = {});

// The C ABI's path for 3-D points (LF_LIDAR_POINTS_LIDAR / LF_LIDAR_POINTS_CAMERA): each point
// moved by *lidar_to_camera (LiDAR frame -> left rectified camera frame; null: the points are
// already there), then projected by the ideal rectified pair of `camera` (io::calib_from_camera).
// `lidarflow sequence` takes its scans through here too, so that it gives the C ABI's maps bit for
// bit. Same ownership and errors as above, plus InvalidArgument for a camera outside the ranges
// of core/limits.hpp.
SparseLidar project_to_left_camera(const std::vector<cv::Point3f> &points, const cv::Matx44d *lidar_to_camera,
                                   const StereoCamera &camera, cv::Size image);

}  // namespace lidarflow::lidar
