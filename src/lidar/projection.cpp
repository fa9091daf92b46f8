// SPDX-License-Identifier: MIT
#include "lidar/projection.hpp"

#include <cmath>
#include <cstdio>
#include <string>

#include "core/error.hpp"
#include "core/log.hpp"
#include "core/limits.hpp"
#include "core/maps.hpp"

namespace lidarflow::lidar {
namespace {

void check_inputs(const io::CamToCamCalib &calib, cv::Size image, const ProjectionOptions &opt) {
    require(image.width > 0 && image.height > 0, ErrorCode::InvalidArgument, "projection: empty image size");
    require(calib.camera.valid() && std::isfinite(calib.camera.fx) && std::isfinite(calib.camera.baseline),
            ErrorCode::InvalidArgument, "projection: calibration has no valid stereo camera");
    bool finite = true;
    for (double v : calib.P_rect_02.val) finite = finite && std::isfinite(v);
    for (double v : calib.R_rect_00.val) finite = finite && std::isfinite(v);
    require(finite, ErrorCode::InvalidArgument, "projection: non-finite calibration matrix");
    require(opt.min_depth > 0 && std::isfinite(opt.min_depth), ErrorCode::InvalidArgument,
            "projection: min_depth must be > 0");
}

// Z-buffer of disparities in the left image; kInvalidDisparity where nothing landed.
class DepthBuffer {
public:
    DepthBuffer(const io::CamToCamCalib &calib, cv::Size image, const ProjectionOptions &opt)
        : P_(calib.P_rect_02), fb_(calib.camera.fx * calib.camera.baseline), min_depth_(opt.min_depth),
          map_(filled(image.height, image.width, kInvalidDisparity)) {}

    void add(const cv::Vec3d &x_rect) {
        const cv::Vec3d p = P_ * cv::Vec4d(x_rect[0], x_rect[1], x_rect[2], 1.0);
        const double w = p[2];
        ++dropped_.seen;
        if (!(w > min_depth_)) {
            ++dropped_.behind;
            return;
        }
        int u = 0, v = 0;
        if (!nearest_pixel(p[0] / w, p[1] / w, map_.size(), u, v)) {
            ++dropped_.outside;
            return;
        }
        // A point so close that its disparity leaves the accepted range is not seen by the
        // right camera of any accepted image either.
        const double dd = fb_ / w;
        if (!(dd <= kMaxLidarDisparity)) {
            ++dropped_.too_close;
            return;
        }
        const float d = static_cast<float>(dd);
        float &cell = map_(v, u);
        if (d > cell) cell = d;
    }
    SparseLidar result() const {
        SparseLidar out = SparseLidar::from_map(map_);
        report_dropped_points(dropped_, min_depth_, map_.size(), out.points.size());
        return out;
    }

private:
    cv::Matx34d P_;
    double fb_, min_depth_;
    DisparityMap map_;
    DroppedPoints dropped_;
};

}  // namespace

bool nearest_pixel(double x, double y, cv::Size image, int &px, int &py) {
    // floor(x + 0.5): pixel centres sit at integer coordinates, as in the devkit.
    const double u = std::floor(x + 0.5), v = std::floor(y + 0.5);
    if (!(u >= 0 && v >= 0 && u < image.width && v < image.height)) return false;
    px = static_cast<int>(u);
    py = static_cast<int>(v);
    return true;
}

void report_dropped_points(const DroppedPoints &d, double min_depth, cv::Size image, size_t kept) {
    const size_t dropped = d.behind + d.outside + d.too_close;
    const log::Level level = d.seen > 0 && kept == 0 ? log::Level::Warning : log::Level::Info;
    if (dropped == 0 || !log::enabled(level)) return;
    char part[96];
    std::string text = std::to_string(dropped) + " of " + std::to_string(d.seen) + " LiDAR points dropped:";
    const char *sep = " ";
    if (d.behind) {
        std::snprintf(part, sizeof part, "%s%zu behind the camera (z <= %g m)", sep, d.behind, min_depth);
        text += part, sep = ", ";
    }
    if (d.outside) {
        std::snprintf(part, sizeof part, "%s%zu outside the %dx%d image", sep, d.outside, image.width, image.height);
        text += part, sep = ", ";
    }
    if (d.too_close) {
        std::snprintf(part, sizeof part, "%s%zu nearer than a disparity of %g px", sep, d.too_close,
                      static_cast<double>(kMaxLidarDisparity));
        text += part;
    }
    log::write(level, text + "; " + std::to_string(kept) + " pixels keep a point");
}

SparseLidar project_to_left(const std::vector<io::VelodynePoint> &points, const io::CamToCamCalib &calib,
                            const cv::Matx44d &velo_to_cam, cv::Size image, const ProjectionOptions &opt) {
    check_inputs(calib, image, opt);
    for (double v : velo_to_cam.val)
        require(std::isfinite(v), ErrorCode::InvalidArgument, "projection: non-finite Velodyne-to-camera transform");
    cv::Matx44d rect = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) rect(r, k) = calib.R_rect_00(r, k);
    const cv::Matx44d T = rect * velo_to_cam;
    DepthBuffer buf(calib, image, opt);
    for (const io::VelodynePoint &q : points) {
        require(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z), ErrorCode::InvalidArgument,
                "projection: non-finite Velodyne point");
        const cv::Vec4d x = T * cv::Vec4d(q.x, q.y, q.z, 1.0);
        buf.add(cv::Vec3d(x[0], x[1], x[2]));
    }
    return buf.result();
}

SparseLidar project_to_left(const std::vector<cv::Point3d> &rect_points, const io::CamToCamCalib &calib,
                            cv::Size image, const ProjectionOptions &opt) {
    check_inputs(calib, image, opt);
    DepthBuffer buf(calib, image, opt);
    for (const cv::Point3d &q : rect_points) {
        require(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z), ErrorCode::InvalidArgument,
                "projection: non-finite point");
        buf.add(cv::Vec3d(q.x, q.y, q.z));
    }
    return buf.result();
}

SparseLidar project_to_left_camera(const std::vector<cv::Point3f> &points, const cv::Matx44d *lidar_to_camera,
                                   const StereoCamera &camera, cv::Size image) {
    std::vector<cv::Point3d> moved(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        cv::Vec4d p(points[i].x, points[i].y, points[i].z, 1.0);
        if (lidar_to_camera) p = *lidar_to_camera * p;
        moved[i] = {p[0], p[1], p[2]};
    }
    return project_to_left(moved, io::calib_from_camera(camera), image);
}

}  // namespace lidarflow::lidar
