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

}  // namespace lidarflow::synth
