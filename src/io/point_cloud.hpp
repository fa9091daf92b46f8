// SPDX-License-Identifier: MIT
#pragma once
// The estimator's result as a coloured 3-D point cloud with motion, and its PLY file.
//
// PLY: binary little-endian, one `vertex` element with float x y z (position at t0 [m], left
// rectified camera frame: x right, y down, z forward), float dx dy dz (motion to t1 [m]) and
// uchar red green blue (the left t0 image); when the ego-motion T is known, then float omx omy
// omz (object motion X1 - T X0 [m], t1 camera frame: ~0 on the static world). Readers that skip
// unknown properties read the first nine as before. Binary because a KITTI frame has ~400k
// points; every viewer that reads PLY (MeshLab, CloudCompare, Open3D) reads this form.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/maps.hpp"

namespace lidarflow::io {

struct CloudPoint {
    cv::Vec3f position;  // [m] at t0
    cv::Vec3f motion;    // [m] t1 - t0
    cv::Vec3b rgb;       // red, green, blue
    bool has_object_motion = false;
    cv::Vec3f object_motion;  // [m] X1 - T X0 (has_object_motion only)
};

// One point per pixel that is valid with d0 > 0 and d1 > 0 (lf_get_points3d's rule), in
// row-major order; colour from `left0` (8-bit grey or BGR, same size as the field). Throws
// Error: InvalidArgument for an invalid camera, an empty field or a bad image, SizeMismatch
// when the image size differs. ego: the rigid background motion T (X1 = T X0, metres) to give
// each point its object motion, or null for none; a point whose object motion would not be
// finite is left out.
std::vector<CloudPoint> scene_points(const SceneFlowField &f, const StereoCamera &camera, const cv::Mat &left0,
                                     const cv::Matx44d *ego = nullptr);

// Writes omx omy omz when the points have object motion (all or none must; else
// Error(InvalidArgument)). `camera_note` (one line, may be empty) adds a header comment about the
// camera. Creates missing parent folders. Throws Error(Io) when the file cannot be written.
void write_ply(const std::string &path, const std::vector<CloudPoint> &points, const std::string &camera_note = "");
// Reads what write_ply writes (the same properties in the same order, binary little-endian, with
// or without omx omy omz). Throws Error: Io when unreadable, Format for another layout or a
// truncated file.
std::vector<CloudPoint> read_ply(const std::string &path);

}  // namespace lidarflow::io
