// SPDX-License-Identifier: MIT
#include "matching/cost_cases.hpp"

#include "core/error.hpp"

namespace lidarflow::matching {

float case_cost(const SlotDescriptors &d, CostCase c, int x, int y, int u, int v, int d0, int d1,
                const PatchShape &shape, DescriptorNorm norm, float penalty, D1Terms terms) {
    for (int s = 0; s < 4; ++s) {
        require(d.image[s] != nullptr && !d.image[s]->empty(), ErrorCode::InvalidArgument,
                "case_cost: missing descriptor image");
        require(d.image[s]->width == d.image[0]->width && d.image[s]->height == d.image[0]->height &&
                    d.image[s]->dim == d.image[0]->dim && d.image[s]->bits == d.image[0]->bits,
                ErrorCode::InvalidArgument, "case_cost: descriptor images differ in size, dim or bits");
    }
    const int sx[4] = {x, x - d0, x + u, x + u - d1};
    const int sy[4] = {y, y, y + v, y + v};
    const int ci = static_cast<int>(c);
    const float *weights = case_weights(c, terms);
    float sum = 0;
    for (int t = 0; t < kNumTerms; ++t) {
        const float w = weights[t];
        if (w == 0) continue;
        const Slot a = kTermA[t], b = kTermB[t];
        sum += w * patch_cost(*d.image[a], *d.image[b], sx[a], sy[a], sx[b], sy[b], shape, norm, penalty);
    }
    return sum / kCaseWeightSum[ci];
}

}  // namespace lidarflow::matching
