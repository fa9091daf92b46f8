// SPDX-License-Identifier: MIT
#pragma once
// KITTI calibration files.
//
// calib_cam_to_cam/ID.txt holds one `KEY: v1 v2 ...` line per matrix (row-major). Of these we
// need the rectified projections of the two colour cameras, P_rect_02 (left, camera 2) and
// P_rect_03 (right, camera 3), both 3x4, and the rectifying rotation of the reference camera,
// R_rect_00 (3x3). P_rect_0i maps a point in camera 0's *rectified* frame to camera i's pixels,
// so the translation column carries the offset of camera i: baseline = (P2(0,3) - P3(0,3)) / fx.
//
// calib_velo_to_cam/ID.txt holds `R:` (9 numbers, row-major) and `T:` (3 numbers): the rigid
// transform from the Velodyne frame to camera 0's unrectified frame.
//
// S_rect_02 (optional) is the rectified left image's size. Keys the parsers do not need are
// ignored (KITTI files carry dates, distortion, raw sizes).
#include <string>

#include <opencv2/core.hpp>

#include "core/camera.hpp"

namespace lidarflow::io {

struct CamToCamCalib {
    cv::Matx34d P_rect_02;  // left colour camera, rectified
    cv::Matx34d P_rect_03;  // right colour camera, rectified
    cv::Matx33d R_rect_00;  // rotation camera 0 -> camera 0 rectified
    StereoCamera camera;    // derived from P_rect_02 / P_rect_03 (see header comment)
    cv::Size image_size;    // S_rect_02 (rectified image size) when the file has it; 0x0 = unknown
};

// Parses calib_cam_to_cam text. Throws Error: Io when the file cannot be opened (only a regular
// file of at most 1 MiB is, without blocking: io/read_file.hpp); Format for a missing or
// duplicated key, a wrong number of values, a non-numeric or non-finite value, a P_rect_02 or
// P_rect_03 that is not a pinhole K [I | t] (rows 2 and 3 of K not 0 fy cy / 0 0 1), an R_rect_00
// that is not a rotation, a geometry that is not a rectified stereo pair (fx, fy or baseline <= 0),
// or a camera outside the ranges of core/limits.hpp (e.g. an infinite baseline from finite
// entries). Messages start with the file (`source`).
CamToCamCalib read_calib_cam_to_cam(const std::string &path);

// Same as read_calib_cam_to_cam on text already in memory; `source` names it in messages.
CamToCamCalib parse_calib_cam_to_cam(const std::string &text, const std::string &source);

// Parses calib_velo_to_cam into the 4x4 rigid transform [R T; 0 0 0 1] (Velodyne -> camera 0).
// Throws Error: Io when unreadable; Format for missing/duplicated keys, wrong counts,
// non-finite values, an R that is not a rotation (|R^T R - I| > 1e-3 or det(R) <= 0), or a T with
// an entry beyond kMaxRigTranslation (1000 m).
cv::Matx44d read_calib_velo_to_cam(const std::string &path);
cv::Matx44d parse_calib_velo_to_cam(const std::string &text, const std::string &source);

// Writes P_rect_02, P_rect_03, R_rect_00 (and S_rect_02 when image_size is known) in the KITTI text format, with enough digits that
// read_calib_cam_to_cam returns the same doubles. Creates missing parent folders. Throws
// Error: InvalidArgument for non-finite entries, Io when the file cannot be written.
void write_calib_cam_to_cam(const std::string &path, const CamToCamCalib &calib);

// The ideal rectified pair of a StereoCamera: P_rect_02 = K[I|0], P_rect_03 = K[I|t] with
// t = (-B, 0, 0) (so P_rect_03(0,3) = -fx*B), R_rect_00 = I; camera is copied. Throws
// Error(InvalidArgument) when the camera lies outside the ranges of core/limits.hpp.
CamToCamCalib calib_from_camera(const StereoCamera &camera);

}  // namespace lidarflow::io
