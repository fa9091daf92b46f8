// SPDX-License-Identifier: MIT
#pragma once
// Items listed per bucket (rows, bands of rows), each list in the items' order: a counting sort
// into one flat array, so that a bucket's work reads only its own items, in the order a single
// pass over all of them would.
#include <cstddef>
#include <vector>

namespace lidarflow {

struct BucketLists {
    std::vector<size_t> start;  // bucket b's items are items[start[b] .. start[b + 1])
    std::vector<size_t> items;  // item indices
    size_t begin(int b) const { return start[static_cast<size_t>(b)]; }
    size_t end(int b) const { return start[static_cast<size_t>(b) + 1]; }
};

// Item i (of n) goes to every bucket in [lo, hi] that range(i, lo, hi) sets (none when hi < lo);
// buckets are in [0, buckets).
template <class Range>
BucketLists bucket_lists(size_t n, int buckets, Range range) {
    BucketLists l;
    l.start.assign(static_cast<size_t>(buckets) + 1, 0);
    for (size_t i = 0; i < n; ++i) {
        int lo, hi;
        range(i, lo, hi);
        for (int b = lo; b <= hi; ++b) ++l.start[static_cast<size_t>(b) + 1];
    }
    for (size_t b = 0; b < static_cast<size_t>(buckets); ++b) l.start[b + 1] += l.start[b];
    l.items.resize(l.start.back());
    std::vector<size_t> fill(l.start.begin(), l.start.end() - 1);
    for (size_t i = 0; i < n; ++i) {
        int lo, hi;
        range(i, lo, hi);
        for (int b = lo; b <= hi; ++b) l.items[fill[static_cast<size_t>(b)]++] = i;
    }
    return l;
}

}  // namespace lidarflow
