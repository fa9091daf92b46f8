// SPDX-License-Identifier: MIT
#pragma once
// A stereo rig from any calibration source, as the estimator needs it: the rectified pair every
// stage works in and, for a rig whose images are not rectified yet, each camera's model to
// rectify them with (io/rectify.hpp).
//
// Sources (read_rig; docs/CALIBRATION.md has an example of each):
//  - KITTI calib_cam_to_cam.txt: P_rect_02, P_rect_03, R_rect_00, S_rect_02 (io/calib.hpp);
//  - an OpenCV stereo calibration file (cv::FileStorage YAML or XML): M1 (or K1) D1 M2 (or K2)
//    D2 and R T as OpenCV's stereo_calib sample writes them (X_right = R X_left + T); R1 R2 P1
//    P2 are used when present, else cv::stereoRectify computes them (which needs the image
//    size); the size as image_width + image_height, or imageSize / image_size = [w, h];
//  - two ROS camera_info YAMLs ("LEFT,RIGHT"): camera_matrix, distortion_coefficients,
//    rectification_matrix, projection_matrix, image_width, image_height;
//  - a pinhole pair given by numbers (rig_from_pinhole).
// A rig is already rectified when both distortions are zero, both rectifying rotations are the
// identity and each P's left 3x3 is its K: its images are then used as they are, and every
// source gives the same camera as the KITTI file of that rig.
#include <string>

#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "io/calib.hpp"

namespace lidarflow::io {

// One camera of a rig, ROS camera_info style.
struct RawCamera {
    cv::Matx33d K = cv::Matx33d::eye();                  // intrinsics of the raw images
    cv::Vec<double, 8> D = cv::Vec<double, 8>::all(0);   // k1 k2 p1 p2 k3 k4 k5 k6
    cv::Matx33d R = cv::Matx33d::eye();                  // raw camera -> rectified camera
    cv::Matx34d P = cv::Matx34d::zeros();                // rectified projection (right: P(0,3) = -fx B)
};

struct Rig {
    // The rectified pair, KITTI style: P_rect_02 = left.P, P_rect_03 = right.P, R_rect_00 =
    // left.R, so a calib_velo_to_cam-style transform into the raw left camera composes with
    // io::velo_to_left_rect as KITTI's does; image_size is the images' size (0x0 = unknown).
    CamToCamCalib rect;
    bool rectify = false;    // the images are raw: rectify them with left / right
    RawCamera left, right;   // the cameras (for an already rectified rig: K = P's 3x3, D = 0, R = I)
};

// Largest calibration file read (a real one is a few KB): anything larger is refused unread.
constexpr size_t kMaxCalibrationFileBytes = 1 << 20;

// Reads the rig of `spec`: one file (KITTI or OpenCV, told apart by its content) or
// "LEFT,RIGHT" camera_info files. Throws Error: Io for a missing or unreadable file, a file that
// is not a regular file (a FIFO, a folder) or one above kMaxCalibrationFileBytes; Format for a
// malformed, incomplete or inconsistent one; every message names the file.
Rig read_rig(const std::string &spec);

// The parsers behind read_rig, on text in memory; `source` names it in messages.
Rig parse_opencv_stereo(const std::string &text, const std::string &source);
Rig parse_camera_info_pair(const std::string &left_text, const std::string &left_source, const std::string &right_text,
                           const std::string &right_source);

// An already rectified rig (KITTI file or numbers); image_size 0x0 = unknown. Throws
// Error(InvalidArgument) for a camera outside core/limits.hpp's ranges.
Rig rig_from_kitti(const CamToCamCalib &calib);
Rig rig_from_pinhole(const StereoCamera &camera, cv::Size image_size = {});

// A rig from its two cameras: checks them (finite, pinhole K, rotations, one rectified K for
// both P, a horizontal pair with the right camera on the right), derives the rectified camera
// and whether the images need rectifying. Throws Error(`code`) naming `source`.
Rig rig_from_cameras(const RawCamera &left, const RawCamera &right, cv::Size image_size, const std::string &source,
                     ErrorCode code = ErrorCode::Format);

// "" when the calibration's image size is unknown (0x0) or equals `input`; else a sentence
// saying both sizes.
std::string image_size_mismatch(cv::Size calibration, cv::Size input);

}  // namespace lidarflow::io
