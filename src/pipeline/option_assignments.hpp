// SPDX-License-Identifier: MIT
#pragma once
// `--set KEY=VALUE,KEY=VALUE` of the CLI and bench_pipeline: any key of the option key table
// (option_keys.hpp; include/lidarflow/lidarflow.h lists them), with the same types and bounds
// as over the C ABI, applied to estimator options.
#include <string>
#include <vector>

#include "pipeline/estimator.hpp"

namespace lidarflow::pipeline {

// Applies the assignments in order. Throws Error(InvalidArgument) naming the assignment for an
// unknown key, a malformed or out-of-range value or a missing '='; `options` is then unchanged.
void apply_option_assignments(EstimatorOptions &options, const std::vector<std::string> &assignments);

}  // namespace lidarflow::pipeline
