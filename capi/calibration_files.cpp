// SPDX-License-Identifier: MIT
// lf_read_kitti_calibration / lf_read_calibration: calibration files as an lf_calibration_t, so
// callers do not compose the Velodyne -> rectified-left transform by hand (io/velo_to_left.hpp
// says how) nor rectify a raw rig themselves (io/rig.hpp).
#include <algorithm>
#include <cstring>

#include "convert.hpp"
#include "guard.hpp"
#include "io/calib.hpp"
#include "io/rig.hpp"
#include "io/velo_to_left.hpp"

using lidarflow::ErrorCode;
using lidarflow::require;
using namespace lidarflow::capi;

namespace {

void check_out(const lf_calibration_t *out) {
    require_non_null(out, "out");
    check_calibration_size(out->struct_size, "out");
}

int32_t fill(const lidarflow::io::Rig &rig, const char *velo_to_cam_path, lf_calibration_t *out) {
    const bool v1 = out->struct_size < sizeof(lf_calibration_t);
    require(!(v1 && rig.rectify), ErrorCode::InvalidArgument,
            "this rig's images need rectifying, which an lf_calibration_t of struct_size " +
                std::to_string(out->struct_size) + " cannot describe (needs " +
                std::to_string(sizeof(lf_calibration_t)) + ")");
    lf_calibration_t r = calibration_of_rig(rig);
    if (velo_to_cam_path) {
        const cv::Matx44d T =
            lidarflow::io::velo_to_left_rect(rig.rect, lidarflow::io::read_calib_velo_to_cam(velo_to_cam_path));
        std::memcpy(r.lidar_to_camera, T.val, sizeof r.lidar_to_camera);
        r.has_lidar_to_camera = 1;
    }
    // Only the caller's layout is written; a larger struct keeps its zeroed unknown tail.
    r.struct_size = std::min<uint32_t>(out->struct_size, static_cast<uint32_t>(sizeof r));
    std::memcpy(out, &r, r.struct_size);
    return static_cast<int32_t>(LF_OK);
}

}  // namespace

extern "C" {

LF_API int32_t lf_read_kitti_calibration(const char *cam_to_cam_path, const char *velo_to_cam_path,
                                         lf_calibration_t *out) {
    return guarded(ErrorSink(nullptr), "lf_read_kitti_calibration", [&] {
        require_non_null(cam_to_cam_path, "cam_to_cam_path");
        check_out(out);
        return fill(lidarflow::io::rig_from_kitti(lidarflow::io::read_calib_cam_to_cam(cam_to_cam_path)),
                    velo_to_cam_path, out);
    });
}

LF_API int32_t lf_read_calibration(const char *calibration, const char *velo_to_cam_path, lf_calibration_t *out) {
    return guarded(ErrorSink(nullptr), "lf_read_calibration", [&] {
        require_non_null(calibration, "calibration");
        check_out(out);
        return fill(lidarflow::io::read_rig(calibration), velo_to_cam_path, out);
    });
}

}  // extern "C"
