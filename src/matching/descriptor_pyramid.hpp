// SPDX-License-Identifier: MIT
#pragma once
// The descriptor pyramid of a scene-flow matcher: dense SIFT descriptors of the four images
// (left0, right0, left1, right1) on every level of a factor-0.5 pyramid. The full resolution's
// belong to the two stereo pairs (StereoFeatures, which a stream hands from one frame to the
// next); the coarser levels are the matcher's own, computed from the images and freed before
// the full resolution's are computed, so that a frame never holds all of a pyramid at once.
// Internal to src/matching (scene_flow_matcher.cpp).
#include <memory>
#include <vector>

#include "features/dense_sift.hpp"
#include "matching/matching_options.hpp"
#include "matching/scene_flow_matcher.hpp"

namespace lidarflow::matching {

// The full-resolution descriptors of each pair (both images, their images and sift set), the
// images in parallel.
void describe_pairs(const std::vector<StereoFeatures *> &pairs, const MatchingOptions &opt);

// Pyramid levels: factor 0.5 while the coarser image stays min_coarsest_height high.
int pyramid_levels(const MatchingOptions &o, int width, int height);

struct DescriptorPyramid {
    MatchingOptions opt;
    int width = 0, height = 0;
    // levels[l].desc[i]: image i in (left0, right0, left1, right1) order. Level 0 points into
    // the pairs, the others into coarse[i].
    struct Level {
        int w = 0, h = 0;
        const features::DescriptorImage *desc[4] = {nullptr, nullptr, nullptr, nullptr};
    };
    std::vector<Level> levels;
    // Owners of the full-resolution descriptors: the (left0, right0) and (left1, right1) pairs.
    std::shared_ptr<const StereoFeatures> pair[2];
    // The pairs whose full-resolution descriptors this matcher still has to compute (null: done
    // or reused); the same objects as pair[t].
    StereoFeatures *pending[2] = {nullptr, nullptr};
    // Levels 1.. of each image (coarse[i][l - 1]), this matcher's own; empty once released.
    std::vector<features::DescriptorImage> coarse[4];
    double seconds_features = 0;
    bool reused_t0 = false;

    // Takes copies of the four images (opt, width and height set before): the t0 pair's
    // descriptors from reuse_t0 when it describes the same images, the t1 pair's to be written
    // into `storage` when given; sizes the levels. Computes no descriptor.
    void init(const MatchInput &in, std::shared_ptr<const StereoFeatures> reuse_t0,
              std::shared_ptr<StereoFeatures> storage);
    // lend: into the t1 pair's full-resolution buffers (run_both), else owned storage.
    void describe_coarse(bool lend);
    bool coarse_lent() const;
    void release_coarse();
    void describe_full();
};

}  // namespace lidarflow::matching
