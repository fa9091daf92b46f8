// SPDX-License-Identifier: MIT
#pragma once
// Dense inverse search (Kroeger et al., ECCV 2016): the decoupled stage 1's optical flow.
//
// Why our own: OpenCV's cv::DISOpticalFlow was ~a quarter of a `realtime` pair, most of it in
// parts that do not depend on the descent steps (densification one pixel and one patch at a time,
// every intensity converted to float at every step). This is the same algorithm in the same
// floating-point order (mean-normalised patches, spatial propagation over 8 fixed stripes in two
// sweeps, the initial flow as a candidate at every level, no variational refinement), so the
// flow is OpenCV's bit for bit (tests/test_flow_dis.cpp compares them); it is faster because
// each level's images are converted once, the patch kernels read floats, and the densification
// runs patch by patch over whole rows (vectorised) instead of pixel by pixel.
// bench/bench_flow times the two side by side.
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

namespace lidarflow::flow {

struct DisOptions {
    int finest_scale = 0;         // pyramid level where the search stops (0 = full resolution)
    int patch_size = 8;           // [px], 2..32
    int patch_stride = 4;         // [px], 1..patch_size
    int descent_iterations = 16;  // per patch and level, split over the two sweeps; 0..1000
    int threads = 1;              // OpenMP threads; the flow does not depend on them
    // Throws Error(InvalidArgument) naming the first value out of range.
    void validate() const;
};

// The coarsest pyramid level searched for an image of `size` (OpenCV's rule: a motion of up to a
// quarter of the larger side, levels no smaller than a patch); < finest_scale for images too
// small to search.
int dis_coarsest_scale(cv::Size size, int patch_size);

// One image prepared for searches with patches of patch_size down to finest_scale: its pyramid
// (OpenCV's INTER_AREA reductions) and each level as floats with a replicated border and with
// its Sobel gradients. Built once, it serves any number of searches at those settings, as the
// image searched from or in: a pair's two directions share their images', and a stream's frame
// is t1 of one pair and t0 of the next. Immutable once built: safe to share between threads;
// copies share the levels.
class DisPyramid {
public:
    // Throws Error(InvalidArgument) for an empty or non-gray image, settings out of range, or an
    // image too small for a level at finest_scale (dis_coarsest_scale < finest_scale).
    DisPyramid(const cv::Mat &gray, int finest_scale, int patch_size);
    cv::Size size() const { return size_; }
    int finest_scale() const { return finest_; }
    int patch_size() const { return patch_; }
    int coarsest_scale() const { return coarsest_; }
    struct Planes;
    const Planes &level(int i) const;  // finest_scale <= i <= coarsest_scale

private:
    cv::Size size_;
    int finest_ = 0, patch_ = 0, coarsest_ = -1;
    std::shared_ptr<const std::vector<Planes>> levels_;  // copies share them
};

// The flow from `from` to `to` (8-bit gray, one size, continuous or not): (u, v) per pixel of
// `from` [px]. `initial` (empty, or CV_32FC2 of the images' size) is a candidate at every patch
// and level, as OpenCV's flow argument. Throws Error(InvalidArgument / SizeMismatch) for empty,
// non-gray or mismatched inputs and for images too small for one level at finest_scale
// (dis_coarsest_scale < finest_scale). Reentrant; allocates its own buffers per call.
cv::Mat2f dis_flow(const cv::Mat &from, const cv::Mat &to, const DisOptions &options,
                   const cv::Mat2f &initial = cv::Mat2f());
// The same from prepared images (built at options' finest_scale and patch_size, one size; else
// Error(InvalidArgument / SizeMismatch)).
cv::Mat2f dis_flow(const DisPyramid &from, const DisPyramid &to, const DisOptions &options,
                   const cv::Mat2f &initial = cv::Mat2f());

}  // namespace lidarflow::flow
