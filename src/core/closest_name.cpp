// SPDX-License-Identifier: MIT
#include "core/closest_name.hpp"

#include <algorithm>

namespace lidarflow {
namespace {

size_t edit_distance(const std::string &a, const std::string &b) {
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            const size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

}  // namespace

std::string closest_name(const std::string &word, const std::vector<std::string> &candidates) {
    if (word.empty()) return "";
    for (const std::string &c : candidates)
        if (c.size() > word.size() + 1 && c.compare(c.size() - word.size() - 1, std::string::npos, "." + word) == 0)
            return c;
    const size_t limit = std::max<size_t>(1, word.size() / 3);
    std::string best;
    size_t best_d = limit + 1;
    for (const std::string &c : candidates) {
        const size_t d = edit_distance(word, c);
        if (d < best_d) best_d = d, best = c;
    }
    return best;
}

std::string did_you_mean(const std::string &word, const std::vector<std::string> &candidates) {
    const std::string c = closest_name(word, candidates);
    return c.empty() ? "" : " (did you mean '" + c + "'?)";
}

}  // namespace lidarflow
