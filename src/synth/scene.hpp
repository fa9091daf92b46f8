// SPDX-License-Identifier: MIT
#pragma once
// Synthetic rectified stereo pair at t0 and t1 with exact ground truth, for tests and the demo.
//
// The scene is a street seen from a KITTI-like stereo rig: a textured ground with lane
// markings, a textured facade behind, four textured boxes ("cars") that move rigidly
// (translation + yaw), one uniformly coloured moving box (textureless: stereo matching has no
// signal there), and a dark, low-contrast shadow on the ground. The camera moves forward and
// yaws slightly between t0 and t1. Every pixel is ray-cast (area-sampled with s x s rays);
// textures are procedural and seeded, so a seed fixes the output bit for bit, on any number of
// threads.
//
// Ground truth follows KITTI Scene Flow 2015, for each pixel p of the left t0 image:
//   d0 = fx*B/Z, and with the point moved by its object's motion and seen from the left
//   camera at t1: flow (u, v) = projection - p, d1 = fx*B/Z1 (d1 lives in the t0 frame).
//   *_occ: every pixel whose point is in front of the t1 camera (Z1 > 0.1 m) and projects into
//          the image ([0, W-1] x [0, H-1]); disp0_occ: every pixel with a surface.
//   *_noc: additionally visible (exact ray-cast occlusion test) in the other views:
//          disp0_noc in the right t0 image, flow_noc in the left t1 image, disp1_noc in the
//          left t1 and the right t1 images; the correspondence must also lie inside the image.
#include <cstdint>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "io/calib.hpp"
#include "io/velodyne.hpp"

namespace lidarflow::synth {

struct SynthConfig {
    uint64_t seed = 1;        // fixes layout, motions, textures and noise
    int width = 640, height = 192;
    double fx = 0;            // focal length [px] (fy = fx); 0 = 0.58 * width (KITTI-like)
    double baseline = 0.54;   // [m], KITTI's
    double noise_sigma = 1.0; // Gaussian sensor noise, std. dev. in 8-bit grey levels; 0 = none
    int lidar_points = 88;    // points per LiDAR frame (paper: ~88)
    double lidar_noise = 0.0; // Gaussian noise added to LiDAR disparities [px]; 0 = exact
    int supersampling = 2;    // s x s rays per pixel (area sampling against aliasing)
    int threads = 0;          // OpenMP threads for this call; 0 = OpenMP's default
};

struct SynthScene {
    SynthConfig config;
    StereoCamera camera;                 // cx = (W-1)/2, cy = 0.46 (H-1), fy = fx
    cv::Mat left0, right0, left1, right1;  // CV_8UC3, BGR

    DisparityMap disp0_occ, disp0_noc;   // d0 per pixel of left t0
    DisparityMap disp1_occ, disp1_noc;   // d1 per pixel of left t0 (warped to t0, as KITTI)
    FlowField flow_occ, flow_noc;        // left t0 -> left t1

    SparseLidar lidar0;  // aligned to left t0, jittered grid, exact d0 (+ lidar_noise)
    SparseLidar lidar1;  // aligned to left t1 (its own grid and depth), NOT warped to t0

    cv::Mat1b textureless_mask;  // 255 where left t0 sees the uniform box, else 0
    cv::Mat1b shadow_mask;       // 255 where left t0 sees the shadowed ground, else 0
    cv::Mat1b labels0;           // surface per pixel of left t0: 1 ground, 2 wall, 3+ boxes
    cv::Mat1f depth_left0, depth_left1;  // depth Z [m] at the pixel centres, left t0 / left t1

    cv::Vec3d ego_translation;  // left camera centre at t1 in the t0 camera frame [m]
    double ego_yaw = 0;         // camera rotation about its y axis from t0 to t1 [rad]
};

// Renders the scene of `config`. The result owns all its data. Throws Error(InvalidArgument)
// for sizes outside [32, 8192], non-finite or non-positive fx/baseline, negative or
// non-finite noise, lidar_points < 0 or above the pixel count, supersampling outside [1, 8],
// or threads < 0.
SynthScene render(const SynthConfig &config);

// A continuous drive through the scene of config.seed (`lidarflow synth --drive`): the scene's
// t0 -> t1 motions (the ego-motion and every box's) repeated once per frame, frame k at time k,
// so pair k -> k+1 of the drive looks like render()'s pair, moved on by k steps. Each frame is
// rendered once with its own noise, so consecutive pairs share their images bit for bit.
// Longer drives would run into the car ahead for the faster ego-motions of make_street_scene
// (each seed's drive is checked against its cars), and the street itself is finite: its end
// wall stands 40-50 m ahead of a camera that moves 0.7-1.1 m and turns up to 1 deg a frame.
constexpr int kMaxDriveFrames = 12;

struct DriveFrame {
    cv::Mat left, right;                   // CV_8UC3, BGR
    std::vector<io::VelodynePoint> scan;   // simulated Velodyne scan in the LiDAR frame
};

// The rig of a drive, as KITTI raw describes it: camera 0 is the reference, the left camera
// (camera 2) sits 0.06 m to its right and the rectification R_rect_00 is a 0.3 deg rotation, so
// P_rect_02 has an offset column as KITTI's does; the LiDAR is mounted as KITTI's (axes x
// forward, y left, z up; 0.27 m behind and 0.08 m above the left camera, tilted 0.5 deg).
// drive_calibration: P_rect_02 / P_rect_03 / R_rect_00 (its camera is render()'s for
// `config`); drive_velo_to_cam: calib_velo_to_cam.txt's Velodyne -> camera 0 (unrectified)
// transform, which io::velo_to_left_rect turns back into the LiDAR -> left camera transform.
io::CamToCamCalib drive_calibration(const SynthConfig &config);
cv::Matx44d drive_velo_to_cam();

// The left camera of frame k in frame 0's camera coordinates (camera k -> camera 0, [R | t]:
// the pose line of the KITTI odometry format); the identity for k = 0. Throws like drive frames.
cv::Matx34d drive_camera_pose(const SynthConfig &config, int k);

// Frame k of the drive: both images, and a scan ray-cast from the LiDAR at time k in an
// HDL-64-like pattern: rings from +2 to -24.8 deg elevation over the full turn, at KITTI's
// 0.42 deg between rings and 0.09 deg of azimuth for a focal length of 721 px, both spread by
// 721 / fx otherwise, so that points are as many pixels apart as in KITTI's images. Stored
// ring by ring, each ring from azimuth -180 to +180 deg as KITTI's scans are; only rays that hit
// within 120 m give a point (reflectance: |cos| of the incidence angle). Throws like render(),
// and Error(InvalidArgument) for k outside [0, kMaxDriveFrames) or a seed whose cameras would
// come within 0.5 m of a car by frame k + 1.
DriveFrame render_drive_frame(const SynthConfig &config, int k);

// Ground truth of pair k -> k+1 in the fields of SynthScene (camera, disp*, flow*, masks,
// labels0, ego motion of the pair); images, depth and LiDAR stay empty. Throws like
// render_drive_frame, with k + 1 < kMaxDriveFrames.
SynthScene render_drive_ground_truth(const SynthConfig &config, int k);

}  // namespace lidarflow::synth
