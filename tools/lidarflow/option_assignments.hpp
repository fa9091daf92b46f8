// SPDX-License-Identifier: MIT
#pragma once
// `--set KEY=VALUE,KEY=VALUE`: any option of the C ABI's key table (include/lidarflow/lidarflow.h
// lists them), with the same types and bounds, applied to the CLI's estimator options.
#include <string>
#include <vector>

#include "pipeline/estimator.hpp"

namespace lidarflow::cli {

// Applies the assignments in order. Throws Error(InvalidArgument) naming the assignment for an
// unknown key, a malformed or out-of-range value or a missing '='; `options` is then unchanged.
void apply_option_assignments(pipeline::EstimatorOptions &options, const std::vector<std::string> &assignments);

}  // namespace lidarflow::cli
