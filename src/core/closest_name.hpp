// SPDX-License-Identifier: MIT
#pragma once
// "did you mean ...?" for unknown option keys and command-line flags.
#include <string>
#include <vector>

namespace lidarflow {

// The candidate `word` most likely mistyped: one that ends in "." + word (a key given without
// its stage prefix), else the nearest by edit distance if that is at most max(1, |word| / 3).
// "" when none is close.
std::string closest_name(const std::string &word, const std::vector<std::string> &candidates);

// " (did you mean 'X'?)" for closest_name's answer, or "" when there is none.
std::string did_you_mean(const std::string &word, const std::vector<std::string> &candidates);

}  // namespace lidarflow
