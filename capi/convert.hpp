// SPDX-License-Identifier: MIT
#pragma once
// Checked conversions of the C ABI's caller-owned input views into core types. Each function
// copies what it keeps, throws lidarflow::Error with a message naming the offending field,
// and never reads outside the sizes the caller declared.
#include <opencv2/core.hpp>

#include "core/lidar.hpp"
#include "core/limits.hpp"
#include "handles.hpp"
#include "lidarflow/lidarflow.h"

namespace lidarflow::capi {

// Throws InvalidArgument unless `struct_size` (of the lf_calibration_t `what` names) is
// LF_CALIBRATION_V1_SIZE or at least sizeof(lf_calibration_t).
void check_calibration_size(uint32_t struct_size, const char *what);

// lf_calibration_t of any accepted struct_size (LF_CALIBRATION_V1_SIZE, or sizeof and more
// with a zero unknown tail) -> Calibration. Throws InvalidArgument (see lf_create).
Calibration convert_calibration(const lf_calibration_t &c);

// A rig as an lf_calibration_t (struct_size sizeof): camera, image size, rectify and the raw
// cameras; no lidar_to_camera.
lf_calibration_t calibration_of_rig(const io::Rig &rig);

// Deep copy of an image as 8-bit gray (GRAY8) or BGR (RGB8, BGR8). `what` names it in messages.
// Throws InvalidArgument (NULL data, zero or too large size, unknown format) or SizeMismatch
// (stride smaller than a row).
cv::Mat convert_image(const lf_image_t &image, const char *what);

// LiDAR entries -> SparseLidar in an image of `size`. lidar may be NULL (no points). Throws
// InvalidArgument (unknown kind, NULL data with count > 0, non-finite values, disparities
// outside [0, kMaxLidarDisparity], LF_LIDAR_POINTS_LIDAR without a transform) or SizeMismatch
// (stride below 12 bytes). Entries off the image (lidar::nearest_pixel) are dropped and logged.
SparseLidar convert_lidar(const lf_lidar_t *lidar, cv::Size size, const Calibration &calibration);

}  // namespace lidarflow::capi
