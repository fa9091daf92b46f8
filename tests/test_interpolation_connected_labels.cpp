// SPDX-License-Identifier: MIT
// SLIC's connectivity pass (connected_labels) against the flood fill that states its rule: from
// each unlabelled pixel in raster order, the 4-connected component of its label gets the next
// number, or, below min_size, the label of the last labelled of its first pixel's left, right,
// upper and lower neighbours. Random label maps from few labels (many small, winding
// components), blocky maps with noise, thin and single-pixel maps, a map inside a larger one
// (not continuous), several min_size; labels and counts must match exactly.
#include <random>
#include <vector>

#include <opencv2/core.hpp>

#include "interpolation/superpixels.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::interpolation;

namespace {

int flood_fill_reference(const cv::Mat1i &in, int min_size, cv::Mat1i &out) {
    const int w = in.cols, h = in.rows;
    out.create(h, w);
    out.setTo(-1);
    std::vector<cv::Point> queue;
    int next = 0;
    const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
    for (int y0 = 0; y0 < h; ++y0)
        for (int x0 = 0; x0 < w; ++x0) {
            if (out(y0, x0) >= 0) continue;
            int adjacent = -1;
            for (int k = 0; k < 4; ++k) {
                const int nx = x0 + dx[k], ny = y0 + dy[k];
                if (nx >= 0 && ny >= 0 && nx < w && ny < h && out(ny, nx) >= 0) adjacent = out(ny, nx);
            }
            queue.assign(1, cv::Point(x0, y0));
            out(y0, x0) = next;
            for (size_t q = 0; q < queue.size(); ++q)
                for (int k = 0; k < 4; ++k) {
                    const int nx = queue[q].x + dx[k], ny = queue[q].y + dy[k];
                    if (nx < 0 || ny < 0 || nx >= w || ny >= h || out(ny, nx) >= 0 || in(ny, nx) != in(y0, x0)) continue;
                    out(ny, nx) = next;
                    queue.emplace_back(nx, ny);
                }
            if (static_cast<int>(queue.size()) < min_size && adjacent >= 0)
                for (const cv::Point &p : queue) out(p.y, p.x) = adjacent;
            else
                ++next;
        }
    return next;
}

cv::Mat1i random_labels(std::mt19937 &gen, int w, int h, int alphabet) {
    cv::Mat1i m(h, w);
    std::uniform_int_distribution<int> pick(0, alphabet - 1);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) m(y, x) = pick(gen);
    return m;
}

// Grid cells of `cell` px, each its own label, with a share of pixels taking a neighbour cell's.
cv::Mat1i blocky_labels(std::mt19937 &gen, int w, int h, int cell, double noise) {
    cv::Mat1i m(h, w);
    const int gx = (w + cell - 1) / cell;
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uniform_int_distribution<int> shift(-1, 1);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            int cx = x / cell, cy = y / cell;
            if (unit(gen) < noise) {
                cx = std::max(0, cx + shift(gen));
                cy = std::max(0, cy + shift(gen));
            }
            m(y, x) = cy * gx + cx;
        }
    return m;
}

void check(const cv::Mat1i &in, int min_size, int *compared) {
    cv::Mat1i want, got;
    const int want_count = flood_fill_reference(in, min_size, want);
    const int got_count = connected_labels(in, min_size, got);
    assert_int_equal(got_count, want_count);
    assert_true(got.size() == in.size());
    assert_int_equal(cv::countNonZero(got != want), 0);
    ++*compared;
}

void matches_the_flood_fill(void **) {
    std::mt19937 gen(21);
    int compared = 0;
    for (int min_size : {1, 2, 5, 30, 100000}) {
        for (int alphabet : {2, 3, 5}) check(random_labels(gen, 61, 47, alphabet), min_size, &compared);
        for (double noise : {0.0, 0.05, 0.3}) check(blocky_labels(gen, 97, 41, 9, noise), min_size, &compared);
        for (const cv::Size s : {cv::Size(1, 1), cv::Size(1, 40), cv::Size(40, 1), cv::Size(2, 2)})
            check(random_labels(gen, s.width, s.height, 2), min_size, &compared);
        const cv::Mat1i big = random_labels(gen, 80, 60, 3);
        check(big(cv::Rect(7, 5, 50, 40)), min_size, &compared);  // a view: rows not contiguous
    }
    assert_int_equal(compared, 5 * 11);
}

// A map of one label is one component; a chessboard is all single pixels, each joining the
// label of the pixel left of (or above) its first pixel unless min_size is 1.
void extreme_maps(void **) {
    cv::Mat1i one(30, 20, 7), out;
    assert_int_equal(connected_labels(one, 1000, out), 1);
    assert_int_equal(cv::countNonZero(out), 0);
    cv::Mat1i chess(6, 5);
    for (int y = 0; y < 6; ++y)
        for (int x = 0; x < 5; ++x) chess(y, x) = (x + y) % 2;
    assert_int_equal(connected_labels(chess, 1, out), 30);
    assert_int_equal(connected_labels(chess, 2, out), 1);
    assert_int_equal(cv::countNonZero(out), 0);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(matches_the_flood_fill),
        cmocka_unit_test(extreme_maps),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
