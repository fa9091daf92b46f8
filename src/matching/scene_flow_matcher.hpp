// SPDX-License-Identifier: MIT
#pragma once
// Stage 1 of LiDAR-Flow: coarse-to-fine PatchMatch over the 4-D scene flow (u, v, d0, d1)
// (CPM-style, extended to scene flow as in SceneFlowFields), with the paper's four LiDAR cost
// cases, support windows and constraints (see matching_options.hpp for the exact rules).
//
// Algorithm (per direction):
//  1. Gray pyramids (factor 0.5) of the four images and dense SIFT descriptors on every level.
//  2. Seeds: a regular grid (grid_step px) plus, with LiDAR, every D_l^0 pixel (its own seed,
//     d0 fixed). The same seeds, scaled, live on every level.
//  3. Coarsest level: random (u, v) within max_flow, random d0 (or the nearest D_l^0 value in
//     the seed's support window), d1 = d0. Each level runs PatchMatch: in every iteration each
//     seed tries its neighbours' matches (propagation) and random candidates with shrinking
//     radius for (u, v), d0 and d1 separately (random search); a candidate is kept if its
//     cost is lower (constraint 1). A finer level starts from the coarser result (x2) with a
//     per-seed search radius given by how much its neighbours disagree.
//  4. Dense output: each pixel takes the match of its grid seed; LiDAR pixels keep their own.
//
// Determinism: seed rows are cut into fixed strips, coloured so that strips of one colour never
// read each other's seeds; colours run in order (a strip waits only for the earlier-coloured
// strips next to it), then the LiDAR seeds, each strip scanned sequentially (alternating
// direction per iteration). Random numbers are a counter-based hash of (random_seed, level, iteration, seed),
// so results are identical for any thread count.
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "core/lidar.hpp"
#include "core/maps.hpp"
#include "matching/cost_cases.hpp"
#include "matching/matching_options.hpp"

namespace lidarflow::matching {

// Caller-owned views; the matcher copies what it needs in its constructor.
struct MatchInput {
    cv::Mat left0, right0, left1, right1;  // 8-bit gray or BGR(A), all the same size
    SparseLidar lidar0;  // D_l^0, aligned to left0 (may be empty: no points)
    SparseLidar lidar1;  // D_l^1, aligned to left1 (may be empty)
};

// Forward: reference I_l^0, t0 -> t1. Backward: reference I_l^1, t1 -> t0 (images and LiDAR
// roles swapped; the result lives in I_l^1's pixel grid).
enum class Direction { Forward, Backward };

struct SeedMatch {
    int x = 0, y = 0;                 // full-resolution pixel of the reference image
    float u = 0, v = 0, d0 = 0, d1 = 0;
    float cost = 0;                   // case_cost(cost_case, ...) of the match (lower is better)
    CostCase cost_case = CostCase::Image;
    bool is_lidar = false;            // a pixel of the reference LiDAR scan (d0 = measurement)
    bool in_window = false;           // inside a reference LiDAR support window
};

struct MatchResult {
    // 100% dense: every pixel valid. confidence = 1 / (1 + cost / 100).
    SceneFlowField dense;
    std::vector<SeedMatch> seeds;  // grid seeds first (row-major), then extra LiDAR seeds
    int grid_width = 0, grid_height = 0;
    double seconds_features = 0, seconds_matching = 0;
    // Candidates not evaluated because their seed had tried their positions before on the same
    // level and case (MatchingOptions::remember_tried): a count for benchmarks and tests.
    uint64_t tried_skips = 0;
};

// The full-resolution descriptors of one stereo pair (left, right) at one time step, with deep
// copies of the 8-bit images they describe. Immutable once handed out; shared (shared_ptr) so
// that a stream can hand the newer pair of one frame to the next frame's matcher. The coarser
// pyramid levels are not part of it: each matcher computes its own from the images (a third of
// the pixels, ~a quarter of the descriptor time) and frees them before it computes the
// full-resolution descriptors, so that a frame never holds all of a pyramid at once.
struct StereoFeatures {
    cv::Mat left, right;
    features::DenseSiftOptions sift;
    features::DescriptorImage desc[2];  // [0] left, [1] right

    // True when these are the descriptors of exactly (l, r) (pixel-identical) under the
    // options' descriptor settings. Never throws.
    bool matches(const cv::Mat &l, const cv::Mat &r, const MatchingOptions &o) const;
};

// The full-resolution descriptors of one stereo pair, as a matcher computes a pair's, to pass as
// a later matcher's reuse_t0 (a stream's first frame, before its pair exists). Throws
// lidarflow::Error for empty, unequal or non-8-bit images and bad options.
std::shared_ptr<const StereoFeatures> stereo_features(const cv::Mat &left, const cv::Mat &right,
                                                      const MatchingOptions &options);

// Both directions of one matcher (SceneFlowMatcher::run_both).
struct MatchPair {
    MatchResult forward, backward;
};

// Not thread-safe: one thread uses a matcher at a time (each call parallelises internally).
class SceneFlowMatcher {
public:
    // Validates and copies the input; computes no descriptor. The coarse levels' descriptors are
    // computed by run and run_both, the full resolution's by the first run, run_both or
    // features_t1.
    // reuse_t0 (may be null): the previous frame's features_t1(); used for (left0, right0)
    // when it matches them (StereoFeatures::matches), ignored otherwise.
    // Throws lidarflow::Error: SizeMismatch (image / LiDAR sizes differ),
    // InvalidArgument (empty or non-8-bit images, LiDAR points outside the image, not finite
    // or negative disparities, bad options).
    // storage (may be null): a pair nobody else holds any more (release_t0() of an earlier
    // matcher); the new (left1, right1) descriptors are written into its buffers.
    SceneFlowMatcher(const MatchInput &input, const MatchingOptions &options,
                     std::shared_ptr<const StereoFeatures> reuse_t0 = nullptr,
                     std::shared_ptr<StereoFeatures> storage = nullptr);
    ~SceneFlowMatcher();
    SceneFlowMatcher(const SceneFlowMatcher &) = delete;
    SceneFlowMatcher &operator=(const SceneFlowMatcher &) = delete;

    // Runs one direction; may be called repeatedly, results depend only on inputs and options.
    MatchResult run(Direction direction);
    // Both directions, with results identical to run(Forward) and run(Backward), level by
    // level: the coarse levels of both, then their descriptors are freed, then the full
    // resolution's are computed and matched. Why: the four full pyramids were the process's
    // peak (~317 MB on a KITTI frame, ~75 MB of it the coarse levels).
    MatchPair run_both();

    // Seconds spent computing descriptors so far.
    double seconds_features() const;
    // The (left1, right1) descriptors, to pass as reuse_t0 of the next frame of a sequence
    // (computed now if no run has yet).
    std::shared_ptr<const StereoFeatures> features_t1();
    // Whether the constructor took (left0, right0)'s descriptors from reuse_t0.
    bool reused_t0() const;
    // Ends this matcher's use (run() then throws InvalidArgument) and hands back the (left0,
    // right0) pair as `storage` for a later matcher when nothing else holds it (else null).
    // Why: a stream's descriptor images are ~120 MB per KITTI pair; fresh ones cost the kernel
    // a page fault and a page clear per 4 KiB (or 2 MiB) on every frame.
    std::shared_ptr<StereoFeatures> release_t0();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Convenience: builds a matcher and runs one direction.
MatchResult match_scene_flow(const MatchInput &input, const MatchingOptions &options,
                             Direction direction);

}  // namespace lidarflow::matching
