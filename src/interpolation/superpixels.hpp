// SPDX-License-Identifier: MIT
#pragma once
// SLIC over-segmentation of the reference image into compact superpixels that follow colour
// boundaries; the interpolation fits one set of piecewise models per superpixel.
// Own implementation (pixel-centric: each pixel compares only the 9 grid-neighbouring centres)
// because OpenCV's SLIC costs 100-250 ms on a KITTI frame and is not per-call threadable.
#include <vector>

#include <opencv2/core.hpp>

namespace lidarflow::interpolation {

struct SuperpixelOptions {
    int region_size = 16;     // grid step S [px]; superpixels have ~S*S pixels; >= 4
    float compactness = 20.0f;  // weight of spatial vs. Lab colour distance (SLIC's m); > 0
    int iterations = 4;       // k-means iterations; >= 1
    int num_threads = 1;      // OpenMP threads; the result does not depend on it
    // Weight of the squared disparity difference [1 / px^2] against Lab's squared distance,
    // where a disparity map is given and both the pixel and its centre have one; 0 = colour only.
    float disparity_weight = 0.0f;
};

struct Superpixels {
    cv::Mat1i labels;                   // label per pixel, 0 .. count-1, each label 4-connected
    int count = 0;
    std::vector<cv::Point2f> centroid;  // centre of mass per label
    std::vector<cv::Point> anchor;      // the label's own pixel closest to its centroid
    std::vector<int> pixel_count;
    // Adjacency (4-neighbourhood), CSR: neighbours of s are adj[adj_start[s] .. adj_start[s+1]).
    std::vector<int> adj_start, adj;
    // Superpixels merged into each label (merge_planar_superpixels); empty: one each.
    std::vector<int> parts;
};

// Segments an 8-bit gray or BGR image; with `disparity` (same size, invalid < 0 or non-finite;
// empty = none) and a disparity_weight > 0, also by depth, so that superpixels end at depth
// boundaries that the colours do not show. Throws Error(InvalidArgument) on an empty or
// unsupported image, a disparity map of another size or options out of range. Deterministic.
Superpixels compute_superpixels(const cv::Mat &image, const SuperpixelOptions &options,
                                const cv::Mat1f &disparity = cv::Mat1f());

// The superpixels of a label map (labels 0 .. count-1, each 4-connected, every label used):
// centroids, anchors, pixel counts and adjacency, as compute_superpixels returns them; the same
// for any `threads` in [1, 1024]. Pure and thread-safe.
Superpixels superpixels_from_labels(cv::Mat1i labels, int count, int threads = 1);

// sp.adj_start / sp.adj (CSR) from each label's neighbour list, which it sorts and dedupes in
// place. Pure but for its arguments.
void set_adjacency(Superpixels &sp, std::vector<std::vector<int>> &neighbours);

// SLIC's connectivity pass: `out` (reallocated) numbers the 4-connected components of `in` in the
// raster order of their first pixels; a component of fewer than min_size pixels instead takes
// the label of the last of its first pixel's left, right, upper and lower neighbours (in that
// order) lying in an earlier component, when it has one (as a flood fill from each first pixel
// in raster order leaves them). Returns the number of labels. Pure and thread-safe.
int connected_labels(const cv::Mat1i &in, int min_size, cv::Mat1i &out);

// Makes OpenCV build its 8-bit Lab tables (~70 ms, once per process) now rather than in the
// first compute_superpixels: a stream's first frame is then as fast as the next. Thread-safe.
void prepare_superpixels();

}  // namespace lidarflow::interpolation
