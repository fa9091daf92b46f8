// SPDX-License-Identifier: MIT
// Template body of SeedSearch::nearest (included by geodesic.hpp only).
#include <algorithm>
#include <cstdint>
#include <cstring>

namespace lidarflow::interpolation {

// A heap entry as one integer: a non-negative float's bits order as the float does, so
// (distance, seed) compare as the pair would, in one instruction.
inline uint64_t SeedSearch::key(float d, int s) {
    uint32_t bits;
    std::memcpy(&bits, &d, sizeof bits);
    return static_cast<uint64_t>(bits) << 32 | static_cast<uint32_t>(s);
}

namespace detail {
constexpr uint64_t kHeapEnd = ~uint64_t{0};  // above every key: a distance's bits are below NaN's
}

inline void SeedSearch::KeyHeap::clear() {
    std::fill(a_.begin(), a_.begin() + static_cast<std::ptrdiff_t>(std::min(size_, a_.size())), detail::kHeapEnd);
    size_ = 0;
}

inline void SeedSearch::KeyHeap::place(size_t i, uint64_t k) {
    while (i > 0) {
        const size_t parent = (i - 1) / 2;
        if (a_[parent] <= k) break;
        a_[i] = a_[parent];
        i = parent;
    }
    a_[i] = k;
}

inline void SeedSearch::KeyHeap::push(uint64_t k) {
    if (a_.size() < size_ + 2) a_.resize(2 * size_ + 16, detail::kHeapEnd);
    place(size_++, k);
}

inline uint64_t SeedSearch::KeyHeap::pop() {
    const uint64_t top = a_[0];
    const uint64_t last = a_[--size_];
    a_[size_] = detail::kHeapEnd;
    if (size_ == 0) {
        a_[0] = detail::kHeapEnd;
        return top;
    }
    size_t i = 0;
    for (size_t c = 1; c < size_; c = 2 * i + 1) {
        c += a_[c + 1] < a_[c];  // a missing right child reads kHeapEnd
        a_[i] = a_[c];
        i = c;
    }
    place(i, last);
    return top;
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
    heap_.push(key(dist_[s0], s0));
    while (!heap_.empty()) {
        const uint64_t top = heap_.pop();
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
            heap_.push(key(nd, t));
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
