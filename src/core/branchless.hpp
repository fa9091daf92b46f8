// SPDX-License-Identifier: MIT
#pragma once
// Branch-free "keep the first least", for loops over pixels that should vectorise: gcc 12 does
// not if-convert `if (c < best) { best = c; label = lc; }` (a conditional store), so it stays
// scalar. Unconditional stores and a mask perform the same comparison and give the same result:
// (best, label) become (c, lc) only where c < best, so a tie keeps the earlier candidate.
#include <cstdint>

namespace lidarflow {

inline void keep_first_least(float c, int lc, float &best, int &label) {
    const int32_t take = -static_cast<int32_t>(c < best);  // all ones where c is less
    label = (lc & take) | (label & ~take);
    best = c < best ? c : best;
}

}  // namespace lidarflow
