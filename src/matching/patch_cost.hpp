// SPDX-License-Identifier: MIT
#pragma once
// Patch matching cost E(I_A, I_B, p_A, p_B) of the paper (Eq. 2): the sum, over a square patch
// Omega, of the distance between the dense descriptors of the two images at p_A + o and p_B + o.
//
// Why a sub-sampled patch: neighbouring SIFT descriptors overlap almost completely (each spans
// 4 * cell_size px), so sampling every `step`-th patch pixel keeps the patch's support while
// cutting the work by step^2 (CPM samples a single descriptor). Sample positions are clamped
// into the image; a patch whose *centre* lies outside either image costs a fixed penalty per
// sample instead, so that out-of-image matches neither win for free nor become impossible.
#include <cstdint>
#include <limits>
#include <vector>

#include "features/dense_sift.hpp"

namespace lidarflow::matching {

enum class DescriptorNorm { L2, L1 };

struct PatchShape {
    int radius = 3;  // Omega = (2 radius + 1)^2: 7x7 as in the paper
    int step = 3;    // sample every step-th pixel of Omega (1 = all pixels)
    std::vector<int> dx, dy;

    PatchShape() = default;
    // Throws InvalidArgument unless radius >= 0 and 1 <= step.
    PatchShape(int radius, int step);
    int samples() const { return static_cast<int>(dx.size()); }
};

// Distance of two descriptors of `dim` bytes (dim a multiple of 16): Euclidean or L1.
float descriptor_distance(const uint8_t *a, const uint8_t *b, int dim, DescriptorNorm norm);

// E over the patch. Both images must have the same dim; positions are integer pixels of their
// own images. Returns samples * penalty when either centre is outside its image. No allocation.
// Early exit: once the running sum exceeds `bound`, that partial sum (> bound) is returned.
float patch_cost(const features::DescriptorImage &a, const features::DescriptorImage &b, int ax,
                 int ay, int bx, int by, const PatchShape &shape, DescriptorNorm norm,
                 float penalty, float bound = std::numeric_limits<float>::infinity());

// The implementation patch_cost() dispatches to on this CPU (AVX2 or SSE2), for hot loops that
// call it millions of times: calling it directly saves the dispatching call's frame (~3 % of a
// frame pair's CPU samples landed on that frame's set-up in perf).
using PatchCostFn = float (*)(const features::DescriptorImage &, const features::DescriptorImage &, int, int,
                              int, int, const PatchShape &, DescriptorNorm, float, float);
// `bits`: the descriptors' (features::DescriptorImage::bits); the function takes only those.
PatchCostFn patch_cost_kernel(int bits);
// The SSE2 / portable implementation, which CPUs without AVX2 get (for tests on those that have it).
PatchCostFn patch_cost_baseline_kernel(int bits);

}  // namespace lidarflow::matching
