// SPDX-License-Identifier: MIT
// superpixels_from_labels: the pixel counts, centroids, anchors (the first pixel in raster order
// nearest the centroid) and adjacency of a label map equal one direct raster pass over it, for
// SLIC's labels and for a map of non-convex and single-pixel regions, on 1, 2, 3, 7 threads
// and on more threads than rows; a thread count out of range is refused.
#include <algorithm>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "interpolation/superpixels.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using namespace lidarflow::interpolation;

namespace {

// The statistics by the definition, serially.
Superpixels direct(const cv::Mat1i &labels, int n) {
    Superpixels sp;
    sp.labels = labels;
    sp.count = n;
    std::vector<double> sx(n, 0.0), sy(n, 0.0);
    sp.pixel_count.assign(n, 0);
    for (int y = 0; y < labels.rows; ++y)
        for (int x = 0; x < labels.cols; ++x) {
            sx[labels(y, x)] += x;
            sy[labels(y, x)] += y;
            ++sp.pixel_count[labels(y, x)];
        }
    for (int l = 0; l < n; ++l)
        sp.centroid.emplace_back(static_cast<float>(sx[l] / sp.pixel_count[l]),
                                 static_cast<float>(sy[l] / sp.pixel_count[l]));
    std::vector<float> best(n, std::numeric_limits<float>::max());
    sp.anchor.assign(n, cv::Point());
    std::vector<std::vector<int>> nb(n);
    for (int y = 0; y < labels.rows; ++y)
        for (int x = 0; x < labels.cols; ++x) {
            const int l = labels(y, x);
            const float dx = x - sp.centroid[l].x, dy = y - sp.centroid[l].y, d = dx * dx + dy * dy;
            if (d < best[l]) best[l] = d, sp.anchor[l] = cv::Point(x, y);
            for (const cv::Point q : {cv::Point(x + 1, y), cv::Point(x, y + 1)})
                if (q.x < labels.cols && q.y < labels.rows && labels(q) != l) {
                    nb[l].push_back(labels(q));
                    nb[labels(q)].push_back(l);
                }
        }
    sp.adj_start.assign(1, 0);
    for (auto &v : nb) {
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
        sp.adj.insert(sp.adj.end(), v.begin(), v.end());
        sp.adj_start.push_back(static_cast<int>(sp.adj.size()));
    }
    return sp;
}

void expect_same(const Superpixels &a, const Superpixels &b) {
    assert_int_equal(a.count, b.count);
    assert_true(a.pixel_count == b.pixel_count);
    assert_true(a.centroid == b.centroid);  // bit for bit
    assert_true(a.anchor == b.anchor);
    assert_true(a.adj_start == b.adj_start);
    assert_true(a.adj == b.adj);
}

void slic_labels(void **) {
    cv::Mat image(97, 151, CV_8UC3);
    cv::setRNGSeed(5);
    cv::randu(image, cv::Scalar::all(40), cv::Scalar::all(220));
    cv::GaussianBlur(image, image, cv::Size(7, 7), 0);
    SuperpixelOptions o;
    o.region_size = 12;
    const Superpixels sp = compute_superpixels(image, o);
    assert_true(sp.count > 50);
    expect_same(sp, direct(sp.labels, sp.count));
    for (int t : {1, 2, 3, 7, 200}) expect_same(superpixels_from_labels(sp.labels.clone(), sp.count, t), sp);
}

void odd_regions(void **) {
    // A ring around a block (its centroid outside it), a comb, one-pixel regions, a band.
    cv::Mat1i labels(40, 60, 0);
    cv::rectangle(labels, cv::Rect(10, 10, 20, 20), 1, cv::FILLED);
    cv::rectangle(labels, cv::Rect(14, 14, 12, 12), 2, cv::FILLED);
    for (int x = 35; x < 58; x += 4) labels(cv::Rect(x, 2, 2, 30)).setTo(3);
    labels(cv::Rect(35, 2, 22, 2)).setTo(3);  // the comb's spine
    labels(0, 59) = 4;
    labels(39, 0) = 5;
    labels.row(38).colRange(20, 60).setTo(6);
    const Superpixels want = direct(labels, 7);
    assert_true(want.anchor[1] != cv::Point(20, 20));  // the ring's anchor is its own pixel
    for (int t : {1, 2, 3, 7, 64}) expect_same(superpixels_from_labels(labels.clone(), 7, t), want);
}

void rejects_bad_threads(void **) {
    const cv::Mat1i labels(4, 4, 0);
    for (int t : {0, -3, 1025})
        test::expect_error([&] { (void)superpixels_from_labels(labels, 1, t); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(slic_labels),
        cmocka_unit_test(odd_regions),
        cmocka_unit_test(rejects_bad_threads),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
