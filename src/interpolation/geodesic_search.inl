// SPDX-License-Identifier: MIT
// Template body of SeedSearch::nearest (included by geodesic.hpp only).
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <functional>

namespace lidarflow::interpolation {

// A heap entry as one integer: a non-negative float's bits order as the float does, so
// (distance, seed) compare as the pair would, in one instruction.
inline uint64_t SeedSearch::key(float d, int s) {
    uint32_t bits;
    std::memcpy(&bits, &d, sizeof bits);
    return static_cast<uint64_t>(bits) << 32 | static_cast<uint32_t>(s);
}

// The traversal settles seeds in order of increasing distance whatever the callers collect,
// and stops as soon as `visit(seed, distance)` says it has enough.
template <class Visit>
void SeedSearch::traverse(const SeedGraph &g, cv::Point from, Visit visit) {
    if (++epoch_ == 0) {  // wrapped: old stamps could alias the new epoch
        std::fill(stamp_.begin(), stamp_.end(), 0u);
        epoch_ = 1;
    }
    // dist_ is valid only where stamp_ == epoch_ (no O(n) reset per query); a settled seed's
    // distance is set negative.
    const int s0 = g.nearest(from.y, from.x);
    heap_.clear();
    dist_[s0] = g.distance(from.y, from.x);
    stamp_[s0] = epoch_;
    heap_.push_back(key(dist_[s0], s0));
    const auto cmp = std::greater<uint64_t>();
    while (!heap_.empty()) {
        std::pop_heap(heap_.begin(), heap_.end(), cmp);
        const uint64_t top = heap_.back();
        heap_.pop_back();
        const int s = static_cast<int>(static_cast<uint32_t>(top));
        float d;
        const uint32_t bits = static_cast<uint32_t>(top >> 32);
        std::memcpy(&d, &bits, sizeof d);
        if (dist_[s] < 0.0f || d > dist_[s]) continue;  // settled or stale entry
        dist_[s] = -1.0f;
        if (visit(s, d)) return;
        for (int e = g.start[s]; e < g.start[s + 1]; ++e) {
            const int t = g.nbr[e];
            const float nd = d + g.weight[e];
            if (stamp_[t] != epoch_) {
                stamp_[t] = epoch_;
                dist_[t] = nd;
            } else if (dist_[t] < 0.0f || nd >= dist_[t]) {
                continue;
            } else {
                dist_[t] = nd;
            }
            heap_.push_back(key(nd, t));
            std::push_heap(heap_.begin(), heap_.end(), cmp);
        }
    }
}

template <class Accept>
void SeedSearch::nearest(const SeedGraph &g, cv::Point from, int k, Accept accept,
                         std::vector<std::pair<int, float>> &out) {
    out.clear();
    if (k <= 0) return;
    out.reserve(static_cast<size_t>(k));  // one allocation, not a doubling series per list
    traverse(g, from, [&](int s, float d) {
        if (accept(s)) out.emplace_back(s, d);
        return static_cast<int>(out.size()) >= k;
    });
}

template <class Accept>
void SeedSearch::nearest_two(const SeedGraph &g, cv::Point from, int k, std::vector<std::pair<int, float>> &out,
                             int k_b, Accept accept_b, std::vector<std::pair<int, float>> &out_b) {
    out.clear();
    out_b.clear();
    const size_t n = static_cast<size_t>(std::max(k, 0)), n_b = static_cast<size_t>(std::max(k_b, 0));
    if (n == 0 && n_b == 0) return;
    out.reserve(n);
    out_b.reserve(n_b);
    traverse(g, from, [&](int s, float d) {
        if (out.size() < n) out.emplace_back(s, d);
        if (out_b.size() < n_b && accept_b(s)) out_b.emplace_back(s, d);
        return out.size() >= n && out_b.size() >= n_b;
    });
}

}  // namespace lidarflow::interpolation
