// SPDX-License-Identifier: MIT
#pragma once
// Disjoint sets held in a parent array in which every element's parent is at most the element
// (a set's root is its least member): uniting hangs the larger root under the smaller, finding
// halves the path. In a raster pass an element's parent is then an earlier element, whose root
// the pass has already resolved (clustering, superpixel connectivity, planar merging). Not
// thread-safe on one array.
#include <algorithm>
#include <vector>

namespace lidarflow {

inline int find_root(std::vector<int> &parent, int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
}

inline void unite_roots(std::vector<int> &parent, int a, int b) {
    a = find_root(parent, a);
    b = find_root(parent, b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

}  // namespace lidarflow
