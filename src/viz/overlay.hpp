// SPDX-License-Identifier: MIT
#pragma once
// Composition helpers for pictures: LiDAR points and masks drawn over images, image grids.
#include <vector>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"

namespace lidarflow::viz {

// Copy of `image` (CV_8UC1 or CV_8UC3; grey is converted to BGR) with each LiDAR point drawn
// as a filled dot of `radius` px in the disparity colour map (max_disp <= 0: largest point
// disparity), ringed in black so it stays visible on any background. Throws Error:
// InvalidArgument for an empty or non-8-bit image or radius < 1, SizeMismatch when the LiDAR
// image size differs from the image.
cv::Mat draw_lidar(const cv::Mat &image, const SparseLidar &lidar, float max_disp = 0, int radius = 3);

// Copy of `image` (CV_8UC1/CV_8UC3) blended with colour `bgr` at opacity alpha in [0, 1] where
// mask != 0. Throws Error: InvalidArgument for bad types or alpha, SizeMismatch for sizes.
cv::Mat overlay_mask(const cv::Mat &image, const cv::Mat1b &mask, const cv::Scalar &bgr, double alpha);

// A colour-coded result drawn over the camera image: where mask != 0 the pixel is
// alpha * colors + (1 - alpha) * image, elsewhere the image dimmed to half brightness so the
// result stands out. image: CV_8UC1/CV_8UC3; colors: CV_8UC3. Throws Error: InvalidArgument for
// bad types or alpha outside [0, 1], SizeMismatch when the sizes differ.
cv::Mat blend_over(const cv::Mat &image, const cv::Mat &colors, const cv::Mat1b &mask, double alpha);

// Grid of CV_8UC3 images, `cols` per row, row-major, with a 4 px black gutter; cells take the
// largest image size (smaller images are top-left aligned). Throws Error(InvalidArgument) for
// no images, cols < 1, or an image that is not CV_8UC3.
cv::Mat tile(const std::vector<cv::Mat> &images, int cols);

}  // namespace lidarflow::viz
