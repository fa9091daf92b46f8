// SPDX-License-Identifier: MIT
#pragma once
// How well a confidence map predicts the error: the SF outlier rate of the pixels that remain
// when the least confident are removed first (a sparsification curve), beside the oracle's,
// which removes the outliers first.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "eval/metrics.hpp"

namespace lidarflow::eval {

struct Sparsification {
    std::vector<double> removed;  // fractions removed: 0, 1/steps, ..., (steps - 1)/steps
    std::vector<double> rate;     // SF outliers of the kept pixels [%], ranked by confidence
    std::vector<double> oracle;   // the same, outliers removed first
    double area = 0;              // mean of rate (the curve's area over [0, 1))
    double oracle_area = 0;
    // rate with 20 % removed over rate with none: the share of the outlier rate that keeping the
    // 80 % most confident pixels leaves (0 for a perfect ranking when outliers are < 20 %).
    double kept80_share = 0;
    long long pixels = 0;  // pixels ranked: all three ground truths and the estimate valid
};

// Ranks the pixels where gt's d0, d1 and flow and the estimate are valid by `confidence`
// (larger first; ties in pixel order) and scores the SF outliers (metrics.hpp's rule) of what
// is kept after removing 0 .. steps-1 tenths (steps >= 2). Throws SizeMismatch for maps of
// another size, InvalidArgument for steps < 2 or no pixel to rank.
Sparsification sparsify(const GroundTruth &gt, const Estimate &est, const cv::Mat1f &confidence, int steps = 10);

// The confidence of frame `id` under dir: confidence/ID_10.npy, ID.npy, ID_10.pfm or ID.pfm
// (the first that exists; `lidarflow kitti --out` and `run --format npy|pfm` write them).
// Throws Io naming the paths tried when none exists, Format as the readers do.
cv::Mat1f load_confidence(const std::string &dir, const std::string &id);

// Text table: one row per frame and their mean.
std::string format_sparsification(const std::vector<std::string> &ids, const std::vector<Sparsification> &s);

}  // namespace lidarflow::eval
