// SPDX-License-Identifier: MIT
#pragma once
// Input checks shared by the consistency stages (internal to src/consistency).
#include <string>

#include "consistency/options.hpp"
#include "core/maps.hpp"

namespace lidarflow::consistency::detail {

// Throws InvalidArgument for an empty field or a non-finite value at a valid pixel, SizeMismatch
// when the planes differ in size (an empty confidence plane is allowed and reads as 0).
void check_field(const SceneFlowField &f, const std::string &name);

// Throws SizeMismatch unless m is rows x cols.
void check_size(const cv::Mat &m, int rows, int cols, const std::string &name);

// Throws InvalidArgument for a threshold that is not finite and positive, a bad block / grid
// size or bad SGM settings.
void check_options(const ConsistencyOptions &opt);

// Options that passed check_options: constructing one is the check. The steps' internal entry
// points (steps.hpp) take this instead of ConsistencyOptions, so that a frame's walk through
// stages 2-3 checks its options once. Refers to `opt`, which must outlive it.
class CheckedOptions {
public:
    explicit CheckedOptions(const ConsistencyOptions &opt) : opt_(opt) { check_options(opt_); }
    const ConsistencyOptions &get() const { return opt_; }

private:
    const ConsistencyOptions &opt_;
};

// Matcher confidence at (y, x); 0 when the field has no confidence plane.
inline float confidence_at(const SceneFlowField &f, int y, int x) {
    return f.confidence.empty() ? 0.0f : f.confidence(y, x);
}

// Copies the match at (y, x) of src into dst and marks it valid.
inline void keep_match(SceneFlowField &dst, const SceneFlowField &src, int y, int x) {
    dst.u(y, x) = src.u(y, x);
    dst.v(y, x) = src.v(y, x);
    dst.d0(y, x) = src.d0(y, x);
    dst.d1(y, x) = src.d1(y, x);
    dst.confidence(y, x) = confidence_at(src, y, x);
    dst.valid(y, x) = 1;
}

}  // namespace lidarflow::consistency::detail
