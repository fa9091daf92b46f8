// SPDX-License-Identifier: MIT
#pragma once
// The four matching-cost cases of the paper (Eqs. 3, 7, 10, 12) over the six constancy terms
// (Eqs. 4-6, 8-9, 11), as the matcher evaluates them.
//
// For a reference pixel p = (x, y) and a match (u, v, d0, d1) the four images are compared at
//   I_l^0: p,  I_r^0: p - (d0, 0),  I_l^1: p + (u, v),  I_r^1: p + (u - d1, v).
// Why normalised: the cases sum 3, 4, 4 and 5 (weighted) terms; the matcher reports and
// compares the weighted *mean* so that costs of different cases live on one scale.
#include "features/dense_sift.hpp"
#include "matching/patch_cost.hpp"

namespace lidarflow::matching {

// Image slots as seen from the reference view.
enum Slot { kL0 = 0, kR0 = 1, kL1 = 2, kR1 = 3 };

// Constancy terms and the images they compare.
enum Term { kTl0l1 = 0, kTl0r0, kTl0r1, kTr0r1, kTr0l1, kTl1r1, kNumTerms };
constexpr Slot kTermA[kNumTerms] = {kL0, kL0, kL0, kR0, kR0, kL1};
constexpr Slot kTermB[kNumTerms] = {kL1, kR0, kR1, kR1, kL1, kR1};

enum class CostCase { Image = 0, LidarD0 = 1, LidarD1 = 2, LidarD0D1 = 3 };

// Term weights per case, index = int(CostCase) = d0case + 2 * d1case.
constexpr float kCaseWeights[4][kNumTerms] = {
    {1, 1, 1, 0, 0, 0},  // C_I         = E(l0,l1) + E(l0,r0) + E(l0,r1)
    {1, 0, 1, 1, 1, 0},  // C_{D_l^0}   = E(l0,l1) + E(l0,r1) + E(r0,r1) + E(r0,l1)
    {1, 1, 0, 1, 0, 1},  // C_{D_l^1}   = E(l0,l1) + E(l0,r0) + E(r0,r1) + E(l1,r1)
    {1, 0, 0, 2, 1, 1},  // C_{D0 D1}   = E(l0,l1) + E(r0,l1) + 2 E(r0,r1) + E(l1,r1)
};
constexpr float kCaseWeightSum[4] = {3, 4, 4, 5};

// Which terms the two D_l^1 cases use (MatchingOptions::d1_terms; see matching_options.hpp).
//  - Paper: Eqs. 10 and 12 as printed, with the t1 stereo term E(l1, r1) (Eq. 11).
//  - ReferenceAnchored: E(l1, r1) is replaced by the cross term E(l0, r1) (Eq. 6), so that every
//    flow-dependent term compares a target patch with a patch of the reference point itself
//    (seen at t0 by the left or the right camera). Same number of terms and the same weight sums.
enum class D1Terms { Paper, ReferenceAnchored };
constexpr float kCaseWeightsAnchored[4][kNumTerms] = {
    {1, 1, 1, 0, 0, 0},      // C_I (unchanged)
    {1, 0, 1, 1, 1, 0},      // C_{D_l^0} (unchanged)
    {1, 1, 1, 1, 0, 0},      // E(l0,l1) + E(l0,r0) + E(l0,r1) + E(r0,r1)
    {1, 0, 1, 2, 1, 0},      // E(l0,l1) + E(r0,l1) + 2 E(r0,r1) + E(l0,r1)
};
// The term weights of case c (kNumTerms values; the sum is kCaseWeightSum[c]).
inline const float *case_weights(CostCase c, D1Terms terms) {
    return terms == D1Terms::Paper ? kCaseWeights[static_cast<int>(c)]
                                   : kCaseWeightsAnchored[static_cast<int>(c)];
}

// Descriptor images of one direction's slots (borrowed; must outlive the call).
struct SlotDescriptors {
    const features::DescriptorImage *image[4] = {nullptr, nullptr, nullptr, nullptr};
};

// Weighted mean of the case's terms at integer positions (as the matcher rounds them).
// Throws InvalidArgument when a slot is missing or the slots differ in size or dim.
float case_cost(const SlotDescriptors &d, CostCase c, int x, int y, int u, int v, int d0, int d1,
                const PatchShape &shape, DescriptorNorm norm, float penalty,
                D1Terms terms = D1Terms::Paper);

}  // namespace lidarflow::matching
