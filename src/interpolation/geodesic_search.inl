// SPDX-License-Identifier: MIT
// Template body of SeedSearch::nearest (included by geodesic.hpp only).
#include <algorithm>
#include <functional>

namespace lidarflow::interp {

template <class Accept>
void SeedSearch::nearest(const SeedGraph &g, cv::Point from, int k, Accept accept,
                         std::vector<std::pair<int, float>> &out) {
    out.clear();
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
    heap_.emplace_back(dist_[s0], s0);
    const auto cmp = std::greater<std::pair<float, int>>();
    int accepted = 0;
    while (!heap_.empty() && accepted < k) {
        std::pop_heap(heap_.begin(), heap_.end(), cmp);
        const auto [d, s] = heap_.back();
        heap_.pop_back();
        if (dist_[s] < 0.0f || d > dist_[s]) continue;  // settled or stale entry
        dist_[s] = -1.0f;
        if (accept(s)) {
            out.emplace_back(s, d);
            ++accepted;
        }
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
            heap_.emplace_back(nd, t);
            std::push_heap(heap_.begin(), heap_.end(), cmp);
        }
    }
}

}  // namespace lidarflow::interp
