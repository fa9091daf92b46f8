// SPDX-License-Identifier: MIT
// lf_read_kitti_calibration: the KITTI calibration files as an lf_calibration_t, so callers do
// not compose the Velodyne -> rectified-left transform by hand (io/velo_to_left.hpp says how).
#include <cstring>

#include "guard.hpp"
#include "io/calib.hpp"
#include "io/velo_to_left.hpp"

using lidarflow::ErrorCode;
using lidarflow::require;
using namespace lidarflow::capi;

extern "C" {

LF_API int32_t lf_read_kitti_calibration(const char *cam_to_cam_path, const char *velo_to_cam_path,
                                         lf_calibration_t *out) {
    return guarded(ErrorSink(nullptr), "lf_read_kitti_calibration", [&] {
        require_non_null(cam_to_cam_path, "cam_to_cam_path");
        require_non_null(out, "out");
        require(out->struct_size >= sizeof(lf_calibration_t), ErrorCode::InvalidArgument,
                "out->struct_size is " + std::to_string(out->struct_size) + ", needs at least " +
                    std::to_string(sizeof(lf_calibration_t)) + " (call lf_calibration_init)");
        const lidarflow::io::CamToCamCalib c = lidarflow::io::read_calib_cam_to_cam(cam_to_cam_path);
        lf_calibration_t r;
        lf_calibration_init(&r);
        r.fx = c.camera.fx;
        r.fy = c.camera.fy;
        r.cx = c.camera.cx;
        r.cy = c.camera.cy;
        r.baseline = c.camera.baseline;
        if (velo_to_cam_path) {
            const cv::Matx44d T =
                lidarflow::io::velo_to_left_rect(c, lidarflow::io::read_calib_velo_to_cam(velo_to_cam_path));
            std::memcpy(r.lidar_to_camera, T.val, sizeof r.lidar_to_camera);
            r.has_lidar_to_camera = 1;
        }
        std::memcpy(out, &r, sizeof r);
        return static_cast<int32_t>(LF_OK);
    });
}

}  // extern "C"
