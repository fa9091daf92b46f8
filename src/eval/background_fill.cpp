// SPDX-License-Identifier: MIT
#include "eval/background_fill.hpp"

#include <algorithm>

#include "core/error.hpp"

namespace lidarflow::eval {
namespace {

// The filling logic is shared by disparity and flow through a small "pixel access" policy:
// valid(i), copy(dst, src) and set_min(dst, a, b) on one line of pixels addressed by index.
// A line is a row or a column; the caller maps the index to (y, x).
template <class Line>
void fill_row_interior_and_ends(Line &line, int n) {
    int first = -1, prev = -1;
    for (int i = 0; i < n; ++i) {
        if (!line.valid(i)) continue;
        if (first < 0) first = i;
        // A gap between two valid pixels: both neighbours exist, take the background value.
        if (prev >= 0 && i - prev > 1)
            for (int k = prev + 1; k < i; ++k) line.set_min(k, prev, i);
        prev = i;
    }
    if (first < 0) return;  // an all-invalid line is left to the column pass
    for (int k = 0; k < first; ++k) line.copy(k, first);
    for (int k = prev + 1; k < n; ++k) line.copy(k, prev);
}

template <class Line>
void extend_ends(Line &line, int n) {
    int first = -1, last = -1;
    for (int i = 0; i < n; ++i)
        if (line.valid(i)) {
            if (first < 0) first = i;
            last = i;
        }
    if (first < 0) return;
    for (int k = 0; k < first; ++k) line.copy(k, first);
    for (int k = last + 1; k < n; ++k) line.copy(k, last);
}

struct DispLine {
    DisparityMap &d;
    int fixed;
    bool is_row;
    float &at(int i) { return is_row ? d(fixed, i) : d(i, fixed); }
    bool valid(int i) { return disparity_valid(at(i)); }
    void copy(int dst, int src) { at(dst) = at(src); }
    void set_min(int dst, int a, int b) { at(dst) = std::min(at(a), at(b)); }
};

struct FlowLine {
    FlowField &f;
    int fixed;
    bool is_row;
    int y(int i) const { return is_row ? fixed : i; }
    int x(int i) const { return is_row ? i : fixed; }
    bool valid(int i) { return f.valid(y(i), x(i)) != 0; }
    void copy(int dst, int src) {
        f.u(y(dst), x(dst)) = f.u(y(src), x(src));
        f.v(y(dst), x(dst)) = f.v(y(src), x(src));
        f.valid(y(dst), x(dst)) = 1;
    }
    void set_min(int dst, int a, int b) {
        f.u(y(dst), x(dst)) = std::min(f.u(y(a), x(a)), f.u(y(b), x(b)));
        f.v(y(dst), x(dst)) = std::min(f.v(y(a), x(a)), f.v(y(b), x(b)));
        f.valid(y(dst), x(dst)) = 1;
    }
};

}  // namespace

DisparityMap fill_background(const DisparityMap &disp) {
    require(!disp.empty(), ErrorCode::InvalidArgument, "fill_background: empty disparity map");
    DisparityMap out = disp.clone();
    // Normalise every invalid value to the devkit's -1, so that unfilled pixels score alike.
    for (int y = 0; y < out.rows; ++y)
        for (int x = 0; x < out.cols; ++x)
            if (!disparity_valid(out(y, x))) out(y, x) = kInvalidDisparity;
    for (int y = 0; y < out.rows; ++y) {
        DispLine line{out, y, true};
        fill_row_interior_and_ends(line, out.cols);
    }
    for (int x = 0; x < out.cols; ++x) {
        DispLine line{out, x, false};
        extend_ends(line, out.rows);
    }
    return out;
}

FlowField fill_background(const FlowField &flow) {
    require(!flow.u.empty(), ErrorCode::InvalidArgument, "fill_background: empty flow field");
    require(flow.u.size() == flow.v.size() && flow.u.size() == flow.valid.size(), ErrorCode::SizeMismatch,
            "fill_background: flow planes u, v, valid differ in size");
    FlowField out{flow.u.clone(), flow.v.clone(), flow.valid.clone()};
    // The devkit's reader stores (0, 0) at invalid pixels; keep that so unfilled pixels score alike.
    for (int y = 0; y < out.height(); ++y)
        for (int x = 0; x < out.width(); ++x)
            if (!out.valid(y, x)) out.u(y, x) = out.v(y, x) = 0.0f;
            else out.valid(y, x) = 1;
    for (int y = 0; y < out.height(); ++y) {
        FlowLine line{out, y, true};
        fill_row_interior_and_ends(line, out.width());
    }
    for (int x = 0; x < out.width(); ++x) {
        FlowLine line{out, x, false};
        extend_ends(line, out.height());
    }
    return out;
}

}  // namespace lidarflow::eval
