// SPDX-License-Identifier: MIT
#pragma once
// Edge-aware (geodesic) neighbourhoods of the sparse matches, EpicFlow-style: one multi-source
// Dijkstra on the pixel grid gives every pixel its geodesically nearest seed (a geodesic
// Voronoi diagram); seeds whose cells touch are linked with the shortest path through the
// shared border. The k nearest seeds of any pixel are then a small Dijkstra on that seed
// graph, which is what makes thousands of per-superpixel queries cheap.
#include <cstdint>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace lidarflow::interpolation {

struct SeedGraph {
    cv::Mat1i nearest;   // index of the geodesically nearest seed per pixel
    cv::Mat1f distance;  // geodesic distance to that seed
    // Seed adjacency, CSR: neighbours of seed i are nbr[start[i] .. start[i+1]) with weight.
    std::vector<int> start, nbr;
    std::vector<float> weight;
    int num_seeds() const { return static_cast<int>(start.size()) - 1; }
};

// Step cost between 4-neighbouring pixels p, q is 1 + edge_gain * (E(p) + E(q)) / 2, so a
// path through flat image regions costs its length in pixels and crossing an edge costs more.
// `seeds` are distinct pixels inside the map (at least one). The seed links on `threads` threads
// (the same graph on any count). Throws Error(InvalidArgument) on an empty map, an edge value
// below 0 or not finite, no seeds, a seed outside the map, or edge_gain < 0 / non-finite.
SeedGraph build_seed_graph(const cv::Mat1f &edges, const std::vector<cv::Point> &seeds, float edge_gain,
                           int threads = 1);

// Reusable scratch for k-nearest-seed queries; one per thread (not thread-safe itself).
class SeedSearch {
public:
    explicit SeedSearch(int num_seeds);
    // Seeds in order of increasing geodesic distance from pixel `from`, as (seed, distance),
    // until `k` accepted seeds were collected or the graph is exhausted; seeds for which
    // accept(seed) is false are skipped (not returned, still traversed). `out` is overwritten.
    template <class Accept>
    void nearest(const SeedGraph &g, cv::Point from, int k, Accept accept,
                 std::vector<std::pair<int, float>> &out);
    // One traversal for two lists from the same pixel: `out` gets the k nearest seeds (as
    // nearest() with every seed accepted), `out_b` the k_b nearest seeds accepted by accept_b.
    // Each list is exactly what its own nearest() call returns (the order in which seeds are
    // settled does not depend on what is collected); the traversal stops once both are full.
    template <class Accept>
    void nearest_two(const SeedGraph &g, cv::Point from, int k, std::vector<std::pair<int, float>> &out, int k_b,
                     Accept accept_b, std::vector<std::pair<int, float>> &out_b);

private:
    template <class Visit>
    void traverse(const SeedGraph &g, cv::Point from, Visit visit);

    // Binary min-heap of distinct keys. pop() walks the hole down by the smaller child without a
    // branch on the keys and then places the last entry (Floyd), where a sift-down's branches
    // mispredicted about half the time; with distinct keys any heap pops the same sequence.
    class KeyHeap {
    public:
        void clear();
        bool empty() const { return size_ == 0; }
        void push(uint64_t k);
        uint64_t pop();

    private:
        void place(size_t i, uint64_t k);  // k into the hole at i, moved up past larger parents
        std::vector<uint64_t> a_;  // slots at and past size_ hold kHeapEnd: a missing child reads it
        size_t size_ = 0;
    };

    std::vector<float> dist_;
    std::vector<unsigned> stamp_;
    unsigned epoch_ = 0;
    static uint64_t key(float d, int s);
    KeyHeap heap_;
};

}  // namespace lidarflow::interpolation

#include "interpolation/geodesic_search.inl"
