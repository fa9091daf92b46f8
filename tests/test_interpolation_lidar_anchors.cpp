// SPDX-License-Identifier: MIT
// The superpixels' LiDAR anchors (associate_lidar) against a brute-force nearest-point search:
// for sparse and dense point sets, points on the image border and superpixels without a point
// nearby, the same anchor, ties to the lower seed index.
#include "test_support.hpp"

#include <limits>
#include <random>
#include <vector>

#include "interpolation/lidar_anchors.hpp"
#include "interpolation/superpixels.hpp"

using namespace lidarflow::interpolation;

namespace {

// Brute force: the nearest accepted seed to the centroid, if it lies inside the superpixel or
// within max_distance of its centroid.
int brute_anchor(const Superpixels &sp, int s, const std::vector<cv::Point> &pos, const std::vector<char> &accept,
                 float max_distance) {
    int best = -1;
    float best_d = std::numeric_limits<float>::infinity();
    for (int i = 0; i < static_cast<int>(pos.size()); ++i) {
        if (!accept[i]) continue;
        const float dx = pos[i].x - sp.centroid[s].x, dy = pos[i].y - sp.centroid[s].y;
        const float d = dx * dx + dy * dy;
        if (d < best_d) best_d = d, best = i;  // ascending i: ties keep the lower index
    }
    if (best < 0) return -1;
    return sp.labels(pos[best]) == s || best_d <= max_distance * max_distance ? best : -1;
}

void anchors_equal_brute_force(void **) {
    std::mt19937 gen(21);
    const cv::Size size(203, 71);
    // Square superpixels of 9 px; the centroids fall on half pixels, where distances tie.
    cv::Mat1i labels(size);
    const int cols = (size.width + 8) / 9;
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) labels(y, x) = (y / 9) * cols + x / 9;
    const Superpixels sp = superpixels_from_labels(labels, cols * ((size.height + 8) / 9));
    int anchored = 0, unanchored = 0;
    for (int points : {0, 1, 5, 60, 2000, 6000}) {
        std::vector<cv::Point> pos;
        cv::Mat1b used(size, 0);
        std::uniform_int_distribution<int> px(0, size.width - 1), py(0, size.height - 1);
        // Corners and edges first: the grid's last cells are partial.
        for (cv::Point p : {cv::Point(0, 0), cv::Point(size.width - 1, size.height - 1), cv::Point(size.width - 1, 0)})
            if (static_cast<int>(pos.size()) < points) used(p) = 1, pos.push_back(p);
        while (static_cast<int>(pos.size()) < points) {
            // Dense points cluster in bands, as a scanner's rows do.
            const cv::Point p(px(gen), points > 1000 ? 15 + py(gen) * 3 / 4 : py(gen));
            if (used(p)) continue;
            used(p) = 1;
            pos.push_back(p);
        }
        std::vector<uint8_t> is_lidar(pos.size()), has_motion(pos.size());
        std::vector<char> lidar(pos.size()), matched(pos.size());
        for (size_t i = 0; i < pos.size(); ++i) {
            is_lidar[i] = lidar[i] = gen() % 4 != 0;
            has_motion[i] = gen() % 2;
            matched[i] = lidar[i] && has_motion[i];
        }
        for (float max_distance : {0.0f, 6.0f, 40.0f}) {
            const LidarAnchors a = associate_lidar(sp, pos, is_lidar, has_motion, max_distance);
            assert_int_equal(a.geometry.size(), sp.count);
            assert_int_equal(a.motion.size(), sp.count);
            for (int s = 0; s < sp.count; ++s) {
                assert_int_equal(a.geometry[s], brute_anchor(sp, s, pos, lidar, max_distance));
                assert_int_equal(a.motion[s], brute_anchor(sp, s, pos, matched, max_distance));
                (a.geometry[s] >= 0 ? anchored : unanchored) += 1;
            }
        }
    }
    assert_true(anchored > 1000);
    assert_true(unanchored > 1000);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(anchors_equal_brute_force),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
