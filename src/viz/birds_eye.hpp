// SPDX-License-Identifier: MIT
#pragma once
// Bird's-eye view of a scene-flow point cloud: the ground plane seen from above (x right, z
// forward, camera at the bottom centre), each point coloured by its speed |motion| (turbo colour
// map, with a colour bar), and arrows of the mean ground-plane motion (dx, dz) of the points in
// each cell, drawn to scale. The motion shown is the object motion (ego-motion removed: the
// static world is still, movers stand out) when the points carry it (io::CloudPoint), else the
// motion relative to the camera, where the static scene shows the ego-motion; the legend says
// which.
#include <vector>

#include <opencv2/core.hpp>

#include "io/point_cloud.hpp"

namespace lidarflow::viz {

struct BirdsEyeOptions {
    double range = 0;      // [m] shown ahead (and range / 2 to each side); 0 = the points' 98th percentile of z in [10, 80]
    int height = 600;      // picture height [px] without the legend (the width is the same)
    double max_speed = 0;  // [m per frame] colour scale; 0 = the 98th percentile of |motion|
    double cell = 2.0;     // [m] one arrow per cell of cell x cell metres
    int min_points = 20;   // cells with fewer points get no arrow
};

// CV_8UC3 picture with its speed legend and the key to its marks (camera, arrows, distance lines). Throws Error(InvalidArgument) for no points, a
// non-finite point, points of which only some have object motion, or options out of range (range < 0, height < 64, max_speed < 0, cell <= 0).
cv::Mat birds_eye_view(const std::vector<io::CloudPoint> &points, const BirdsEyeOptions &options = {});

// The colour of speed s on the view's scale [0, max_speed].
cv::Vec3b speed_color(double s, double max_speed);

}  // namespace lidarflow::viz
