// SPDX-License-Identifier: MIT
#pragma once
// Colour coding of optical flow fields.
#include <opencv2/core.hpp>

#include "core/maps.hpp"

namespace lidarflow::viz {

enum class FlowColorStyle {
    // KITTI devkit (flow_to_color.m): hue = direction atan2(v, u) (u > 0 red, v > 0
    // yellow-green, u < 0 cyan, v < 0 violet), saturation = min(8 |f| / max, 1), value =
    // min(8 - 8 |f| / max, 1): zero flow is white, flows near `max` darken to black.
    Kitti,
    // Middlebury colour wheel (Baker et al.): 55-colour wheel, colour intensity grows with
    // |f| / max; zero flow is white, |f| > max is drawn at 75 % brightness.
    Middlebury,
};

struct FlowColorOptions {
    FlowColorStyle style = FlowColorStyle::Kitti;
    // Normalisation [px]; <= 0: automatic, the largest |u| or |v| over valid pixels (KITTI
    // style) or the largest |f| (Middlebury), as the devkits do.
    float max_flow = 0;
};

// CV_8UC3 BGR picture of `flow`, same size; invalid pixels (valid == 0 or non-finite u, v)
// are black. The result owns its pixels. Throws Error: InvalidArgument for an empty field or
// a non-finite max_flow, SizeMismatch when u, v and valid differ in size.
cv::Mat flow_to_color(const FlowField &flow, const FlowColorOptions &options = {});

// The normalisation flow_to_color uses: options.max_flow when > 0, else the automatic one
// (1 when nothing valid moves). Throws Error(InvalidArgument) for a non-finite max_flow.
double flow_color_scale(const FlowField &flow, const FlowColorOptions &options = {});

// The colour flow_to_color gives to one displacement (u, v) at normalisation max_flow > 0.
cv::Vec3b flow_color(double u, double v, double max_flow, FlowColorStyle style);

}  // namespace lidarflow::viz
