// SPDX-License-Identifier: MIT
#pragma once
// Running the estimator below the input resolution (EstimatorOptions::processing_scale): the
// frame is brought down before stage 1 and every result field back up after the last stage.
// Why: every stage's cost grows with the pixel count, so half resolution is about 4x faster;
// the price is accuracy (see the README's preset table). Only the search ranges scale with the
// image (the estimator does that); windows, thresholds and superpixel size keep their pixel
// values: scaling them too measured worse (KITTI SF at scale 0.5, seeds 1-3: 17.2 % as is,
// 17.7 % with sizes scaled, 20.5 % with the tolerances scaled as well).
#include "core/maps.hpp"
#include "pipeline/estimator.hpp"

namespace lidarflow::pipeline {

// Size of an image of w x h at `scale`: round(w * scale) x round(h * scale), at least 2x2.
cv::Size scaled_size(int w, int h, double scale);

// The frame at `size` (smaller than the input): images area-averaged (core/area_downscale, on
// `threads` OpenMP threads); each LiDAR point moves to the small pixel whose area holds it, with
// its disparity scaled (the larger, nearer one wins a shared pixel); the camera's intrinsics scaled. Throws InvalidArgument / SizeMismatch for
// empty or unequal images and bad LiDAR (as the matcher would at full size). The result owns
// its images.
// t0: the frame's t0 images and points already at `size` (downscale_stereo's, e.g. a prepared
// first frame's), taken as they are; null: downscaled here.
FrameInput downscale_frame(const FrameInput &frame, cv::Size size, const StereoFrame *t0 = nullptr,
                           int threads = 1);

// One stereo pair and its points at `size`, by downscale_frame's rule; unchecked (the caller has
// checked them as downscale_frame does).
StereoFrame downscale_stereo(const cv::Mat &left, const cv::Mat &right, const SparseLidar &lidar, cv::Size size,
                             int threads = 1);

// `small` brought to width x height: a pixel takes the bilinear blend of the four small pixels
// around it when all four are valid, else the value of the nearest small pixel when that one is
// valid, else stays invalid; flow and disparities are multiplied by the size ratio. An empty
// field stays empty. Throws InvalidArgument for a target smaller than `small`.
// With `edges`, a pixel whose four small pixels differ by more than edges->step in d0, u or v
// takes the one of the four nearest it in intensity instead of their blend: a blend across a
// depth or motion edge is a surface in mid-air.
struct EdgeGuide {
    cv::Mat1b small, full;  // gray intensities of the field's image at the small and full size
    float step = 0;         // [small px]; 0 blends everywhere
    EdgeGuide(const cv::Mat &small_image, const cv::Mat &full_image, float step);
};
// Rows are shared among `threads` OpenMP threads (the result does not depend on it).
SceneFlowField upscale_field(const SceneFlowField &small, int width, int height, const EdgeGuide *edges = nullptr,
                             int threads = 1);

// Restores the measured d0 at the LiDAR pixels of an upscaled field where it is valid (the small
// grid averaged them with their neighbours). Points must lie inside the field.
void restore_lidar_d0(SceneFlowField &field, const SparseLidar &lidar0);

}  // namespace lidarflow::pipeline
