// SPDX-License-Identifier: MIT
#include "stereo/speckles.hpp"

#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <vector>

#include "core/error.hpp"
#include "core/threads.hpp"

namespace lidarflow::stereo {

namespace {

// Union-find whose root is the smallest index of its set (path halving): a pixel is linked only
// to earlier ones, so a set made inside one band of rows keeps its parents inside that band.
int find(int *parent, int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
}

void unite(int *parent, int a, int b) {
    a = find(parent, a);
    b = find(parent, b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

}  // namespace

void filter_speckles(cv::Mat1s &disp, int16_t new_value, int max_size, int max_diff, int threads) {
    require(max_diff >= 0, ErrorCode::InvalidArgument, "speckle filter: max_diff must be >= 0");
    if (max_size <= 0 || disp.empty()) return;
    const int h = disp.rows, w = disp.cols;
    require(static_cast<long long>(h) * w < (1LL << 31), ErrorCode::InvalidArgument, "speckle filter: map too large");
    std::vector<int> parent(static_cast<size_t>(h) * w);
    int *par = parent.data();
    const auto joined = [&](int16_t a, int16_t b) {
        return a != new_value && b != new_value && std::abs(a - b) <= max_diff;
    };
    // Row y's pixels with their left and (from the band's second row) upper neighbours.
    const auto link_row = [&](int y, bool left, bool up) {
        const int16_t *row = disp[y], *above = up ? disp[y - 1] : nullptr;
        for (int x = 0, i = y * w; x < w; ++x, ++i) {
            if (left && x > 0 && joined(row[x], row[x - 1])) unite(par, i, i - 1);
            if (up && joined(row[x], above[x])) unite(par, i, i - w);
        }
    };
    const int T = std::max(1, std::min(threads, h / 8));
    for_each_band(h, T, [&](int, int y0, int y1) {
        std::iota(par + static_cast<size_t>(y0) * w, par + static_cast<size_t>(y1) * w, y0 * w);
        for (int y = y0; y < y1; ++y) link_row(y, true, y > y0);
    });
    for (int t = 1; t < T; ++t) link_row(band_start(h, t, T), false, true);
    // Each pixel's root (its parent is an earlier pixel whose root is known by then) and each
    // root's count of pixels.
    std::vector<int> size(parent.size(), 0);
    for (int y = 0; y < h; ++y) {
        const int16_t *row = disp[y];
        for (int x = 0, i = y * w; x < w; ++x, ++i) {
            if (row[x] == new_value) continue;
            const int p = par[i];
            par[i] = p == i ? i : par[p];
            ++size[static_cast<size_t>(par[i])];
        }
    }
#pragma omp parallel for num_threads(T) schedule(static)
    for (int y = 0; y < h; ++y) {
        int16_t *row = disp[y];
        for (int x = 0, i = y * w; x < w; ++x, ++i)
            if (row[x] != new_value && size[static_cast<size_t>(par[i])] <= max_size) row[x] = new_value;
    }
}

}  // namespace lidarflow::stereo
