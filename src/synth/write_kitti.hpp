// SPDX-License-Identifier: MIT
#pragma once
// Writes a rendered synthetic scene in the official KITTI Scene Flow 2015 training layout, so
// every tool that reads KITTI (eval, sample-lidar, the estimator CLI) runs on it unchanged.
#include <string>

#include "synth/scene.hpp"

namespace lidarflow::synth {

// Writes under `root` (folders created as needed), for frame `id` (6 digits):
//   image_2/ID_10.png ID_11.png, image_3/ID_10.png ID_11.png      left / right, t0 / t1
//   disp_occ_0, disp_noc_0, disp_occ_1, disp_noc_1, flow_occ, flow_noc /ID_10.png
//   calib_cam_to_cam/ID.txt                                        P_rect_02, P_rect_03, R_rect_00
//   lidar_0/ID_10.png, lidar_1/ID_10.png    sparse LiDAR disparities (KITTI disparity PNG);
//                                           lidar_1 is aligned to the left t1 image
//   masks/ID_textureless.png, masks/ID_shadow.png                  8-bit, 255 inside
// Throws Error: InvalidArgument for an id that is not 6 digits or an empty scene, Io when a
// file cannot be written.
void write_kitti(const SynthScene &scene, const std::string &root, const std::string &id);

// Paths of the two mask files write_kitti writes.
std::string textureless_mask_path(const std::string &root, const std::string &id);
std::string shadow_mask_path(const std::string &root, const std::string &id);

// A drive (render_drive_frame / render_drive_ground_truth) in the KITTI raw layout, under `root`:
//   image_02/data/NNNNNNNNNN.png, image_03/data/NNNNNNNNNN.png   left / right of frame N
//   velodyne_points/data/NNNNNNNNNN.bin                           its scan (KITTI .bin)
//   {image_02,image_03,velodyne_points}/timestamps.txt            one line per frame, 10 Hz
//   calib_cam_to_cam.txt, calib_velo_to_cam.txt                   the rig (drive_calibration, drive_velo_to_cam)
//   gt/{disp_occ_0,disp_noc_0,disp_occ_1,disp_noc_1,flow_occ,flow_noc}/NNNNNNNNNN.png
//                                                                 pair N -> N+1, KITTI PNGs
//   gt/poses.txt                                                  the left camera per frame (KITTI
//                                                                 odometry format, io/poses.hpp)
// N is the frame index in 10 digits (drive_frame_name). Each function throws Error: Io when a
// file cannot be written, InvalidArgument for a negative index or an empty frame.
std::string drive_frame_name(int k);
void write_drive_rig(const SynthConfig &config, const std::string &root);
void write_drive_timestamps(const std::string &root, int frames);
void write_drive_poses(const SynthConfig &config, const std::string &root, int frames);
void write_drive_frame(const DriveFrame &frame, const std::string &root, int k);
void write_drive_ground_truth(const SynthScene &pair, const std::string &root, int k);

}  // namespace lidarflow::synth
