// SPDX-License-Identifier: MIT
#pragma once
// Semi-global stereo matching with a LiDAR term in its data cost (the decoupled stage 1's
// stereo). OpenCV's StereoSGBM takes no prior, so the project has its own SGM:
//  - data cost: Hamming distance of 9x7 census signatures (0..62, one popcount per candidate,
//    16 candidates a step with AVX2), or of ternary ones (darker / brighter by more than a
//    threshold: two popcounts, halved);
//  - LiDAR term: at and around each LiDAR pixel, + weight * min(slope * |d - d_lidar|, cap),
//    on a map densified within `lidar_radius` px over pixels of similar intensity, the weight
//    falling with the distance to the point (guided stereo matching in its additive form);
//  - smoothness: P1 for a one-pixel step, P2 (divided by the intensity step along the path, at
//    least P1 + 1) for larger ones; 16-bit path costs with the previous pixel's minimum
//    subtracted, so they stay below cost + P2;
//  - 4 paths (both directions of rows and columns) or 8 (and the diagonals);
//  - winner takes all over the summed paths, uniqueness margin, parabola sub-pixel, a left-right
//    check with the right image's disparities read from the same sums, and OpenCV's speckle
//    filter.
// Integer throughout: results do not depend on the thread count or the ISA. Cost model and
// floor: docs/ARCHITECTURE.md, "Guided SGM".
#include <cstdint>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"
#include "core/maps.hpp"

namespace lidarflow::stereo {

struct GuidedSgmOptions {
    int num_disparities = 128;  // search range [0, num_disparities), multiple of 16, <= 512
    // Census: a neighbour's bit is set where it is darker than the centre by more than
    // census_threshold grey levels; ternary adds a second bit for brighter by more than it, so
    // that a flat, noisy surface (all neighbours within the threshold) costs 0 everywhere and
    // the paths fill it, instead of matching its noise.
    bool ternary_census = false;
    int census_threshold = 0;   // [grey levels] 0..64
    int p1 = 10;                // penalty of a 1 px disparity step along a path (census units)
    int p2 = 120;               // penalty of a larger step, before the intensity division
    bool adaptive_p2 = true;    // P2 / (1 + |I(p) - I(p - r)| / 8), at least P1 + 1
    int paths = 8;              // 4 or 8
    int uniqueness_ratio = 10;  // [%] margin of the best sum over those more than 1 px away
    int lr_max_diff = 1;        // left-right tolerance [px]; < 0 disables the check
    int speckle_window = 100;   // regions smaller than this become invalid; 0 = off
    int speckle_range = 2;      // disparity step [px] that splits speckle regions
    // LiDAR term (no effect without points).
    float lidar_slope = 4.0f;   // cost per px of |d - d_lidar| at full weight
    int lidar_cap = 40;         // largest LiDAR penalty (census costs are 0..62)
    int lidar_radius = 3;       // [px] around each point; 0 = the point's pixel only
    int lidar_intensity = 12;   // a neighbour is guided when |I(q) - I(point)| <= this (0..255)
    int threads = 1;            // OpenMP threads; results do not depend on it

    // Throws lidarflow::Error(InvalidArgument) naming the first bad field.
    void validate() const;
};

// The per-pixel prior: disparity and weight (0 = none, 255 = full) of the nearest LiDAR point
// within `lidar_radius` px whose intensity the pixel shares. `gray` is the left image (8-bit,
// one channel); the points live in it. Returns {prior (CV_32F), weight (CV_8U)}.
struct LidarPrior {
    cv::Mat1f disparity;
    cv::Mat1b weight;
};
LidarPrior densify_lidar(const cv::Mat1b &gray, const SparseLidar &lidar, const GuidedSgmOptions &opt);

// Disparity of the rectified pair (8-bit gray or BGR, one size) with the LiDAR points of the
// left image (may be empty: image-only SGM). Returns a new map, kInvalidDisparity where the
// checks reject a pixel or the disparity would point left of I_r. Throws lidarflow::Error:
// InvalidArgument for empty or non-8-bit images, bad options or images over 16384 px a side;
// SizeMismatch when the images or the LiDAR's size differ. Memory: ~3 bytes per pixel and
// disparity. Thread-safe (no shared state).
DisparityMap guided_sgm(const cv::Mat &left, const cv::Mat &right, const SparseLidar &lidar,
                        const GuidedSgmOptions &opt);

namespace detail {
// One row of guided_sgm's data costs, exposed for its test: cost[x * D + d] = the Hamming distance
// of left pixel x's census signature (dl; with `ternary` also the bright plane bl, the sum of both
// halved, rounded up) and right pixel x - d's (dr, br; column 0 stands in left of the image), plus
// the LiDAR penalty where weight[x] > 0 (prior16: the prior in 1/16 px). `simd` takes the AVX2
// loop where the CPU has it, else the scalar one: the same bytes. w pixels, D a multiple of 16.
void row_costs(bool ternary, const uint64_t *dl, const uint64_t *dr, const uint64_t *bl, const uint64_t *br,
               const int16_t *prior16, const uint8_t *weight, int w, int D, int slope16, int cap, bool simd,
               uint8_t *cost);
// One row's two horizontal path costs summed into sum[x * D + d] (w * D values), from the row's
// data costs (row_costs) and gray pixels `img`, with penalties p1 < p2 (adaptive_p2: p2 falls with
// the step in intensity, GuidedSgmOptions). `simd` takes the AVX2 kernel where the CPU has it and
// D <= 128, else the scalar loop: the same sums.
void horizontal_paths(const uint8_t *cost, const uint8_t *img, int w, int D, int p1, int p2, bool adaptive_p2,
                      bool simd, uint16_t *sum);
// Per pixel of one row of summed path costs S (w * D): the disparity of the smallest sum (the
// smallest d on ties), or -1 when a sum more than 1 px away is within the uniqueness margin (0..99
// percent), when there is no such rival, or when the right image's winner at x - d (read from the
// same sums, of equal sums the smallest d) differs by more than lr_max_diff (< 0: no check).
// `simd` takes the AVX2 kernel where the CPU has it and D <= 128, else the scalar loop: the same
// winners. `scratch`: 2 (w + D) values.
void row_winners(const uint16_t *S, int w, int D, int uniqueness, int lr_max_diff, bool simd, uint16_t *scratch,
                 int16_t *best);
}  // namespace detail

}  // namespace lidarflow::stereo
