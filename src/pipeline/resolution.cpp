// SPDX-License-Identifier: MIT
#include "pipeline/resolution.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/area_downscale.hpp"
#include "core/error.hpp"
#include "core/gray.hpp"
#include "core/maps.hpp"

namespace lidarflow::pipeline {
namespace {

SparseLidar downscale_lidar(const SparseLidar &l, cv::Size size, double sx, double sy) {
    SparseLidar out{size.width, size.height, {}};
    if (l.points.empty()) return out;
    // The nearest (largest) disparity per reduced pixel, read back in row-major order: a
    // buffer of the reduced frame (a scan's ~20k points in a tree cost ~2 ms).
    DisparityMap nearest = filled(size, kInvalidDisparity);
    for (const LidarPoint &p : l.points) {
        const int x = std::min(size.width - 1, static_cast<int>(std::floor((p.x + 0.5) * sx)));
        const int y = std::min(size.height - 1, static_cast<int>(std::floor((p.y + 0.5) * sy)));
        float &d = nearest(y, x);
        d = std::max(d, static_cast<float>(p.disparity * sx));  // disparities are >= 0 (validated)
    }
    return SparseLidar::from_map(nearest);
}

}  // namespace

cv::Size scaled_size(int w, int h, double scale) {
    return {std::max(2, static_cast<int>(std::lround(w * scale))), std::max(2, static_cast<int>(std::lround(h * scale)))};
}

StereoFrame downscale_stereo(const cv::Mat &left, const cv::Mat &right, const SparseLidar &lidar, cv::Size size,
                             int threads) {
    const double sx = double(size.width) / left.cols, sy = double(size.height) / left.rows;
    StereoFrame out;
    area_downscale(left, out.left, size, threads);
    area_downscale(right, out.right, size, threads);
    out.lidar = downscale_lidar(lidar, size, sx, sy);
    return out;
}

FrameInput downscale_frame(const FrameInput &f, cv::Size size, const StereoFrame *t0_small, int threads) {
    const cv::Mat *imgs[4] = {&f.left0, &f.right0, &f.left1, &f.right1};
    const char *names[4] = {"left0", "right0", "left1", "right1"};
    for (int i = 0; i < 4; ++i) {
        require(!imgs[i]->empty(), ErrorCode::InvalidArgument, std::string("FrameInput: ") + names[i] + " is empty");
        require(imgs[i]->size() == f.left0.size(), ErrorCode::SizeMismatch,
                std::string("FrameInput: ") + names[i] + " differs in size from left0");
    }
    const int W = f.left0.cols, H = f.left0.rows;
    require(size.width >= 2 && size.height >= 2 && size.width <= W && size.height <= H, ErrorCode::InvalidArgument,
            "downscale_frame: target size must be at least 2x2 and no larger than the frame");
    f.lidar0.validate(W, H, "FrameInput: lidar0");
    f.lidar1.validate(W, H, "FrameInput: lidar1");
    const double sx = double(size.width) / W, sy = double(size.height) / H;
    FrameInput out;
    StereoFrame t0 = t0_small ? *t0_small : downscale_stereo(f.left0, f.right0, f.lidar0, size, threads);
    StereoFrame t1 = downscale_stereo(f.left1, f.right1, f.lidar1, size, threads);
    out.left0 = std::move(t0.left);
    out.right0 = std::move(t0.right);
    out.lidar0 = std::move(t0.lidar);
    out.left1 = std::move(t1.left);
    out.right1 = std::move(t1.right);
    out.lidar1 = std::move(t1.lidar);
    out.camera = f.camera;
    out.step_us = f.step_us;
    if (f.camera.valid()) {
        out.camera.fx = f.camera.fx * sx;
        out.camera.fy = f.camera.fy * sy;
        out.camera.cx = (f.camera.cx + 0.5) * sx - 0.5;
        out.camera.cy = (f.camera.cy + 0.5) * sy - 0.5;
    }
    return out;
}

EdgeGuide::EdgeGuide(const cv::Mat &small_image, const cv::Mat &full_image, float edge_step)
    : small(edge_step > 0 ? gray8(small_image) : cv::Mat1b()), full(edge_step > 0 ? gray8(full_image) : cv::Mat1b()),
      step(edge_step) {}

namespace {

// What the pixels between small pixels (x0, y0) and (x0 + 1, y0 + 1) do, the same for each of them.
enum CellKind : uint8_t { kNearest = 0, kBlend = 1, kAtEdge = 2 };

// kNearest where a corner has no value; kAtEdge where d0, u or v spread over more than the edge
// guide's step across the four corners (with a guide); else kBlend.
CellKind cell_kind(const SceneFlowField &s, const EdgeGuide *g, int x0, int x1, int y0, int y1) {
    if (!(s.valid(y0, x0) && s.valid(y0, x1) && s.valid(y1, x0) && s.valid(y1, x1))) return kNearest;
    if (!g) return kBlend;
    const int cy[4] = {y0, y0, y1, y1}, cx[4] = {x0, x1, x0, x1};
    float spread = 0;
    for (const cv::Mat1f *m : {&s.d0, &s.u, &s.v}) {
        float lo = (*m)(y0, x0), hi = lo;
        for (int c = 1; c < 4; ++c) {
            lo = std::min(lo, (*m)(cy[c], cx[c]));
            hi = std::max(hi, (*m)(cy[c], cx[c]));
        }
        spread = std::max(spread, hi - lo);
    }
    return spread <= g->step ? kBlend : kAtEdge;
}

// The corner (0..3: (y0,x0), (y0,x1), (y1,x0), (y1,x1)) whose small gray value is nearest the
// pixel's own (the first on ties).
int edge_corner(const EdgeGuide &g, int x, int y, int x0, int x1, int y0, int y1) {
    const int cy[4] = {y0, y0, y1, y1}, cx[4] = {x0, x1, x0, x1};
    const int own = g.full(y, x);
    int best = 0, nearest = std::abs(g.small(y0, x0) - own);
    for (int c = 1; c < 4; ++c) {
        const int e = std::abs(g.small(cy[c], cx[c]) - own);
        if (e < nearest) nearest = e, best = c;
    }
    return best;
}

}  // namespace

SceneFlowField upscale_field(const SceneFlowField &small, int width, int height, const EdgeGuide *edges,
                             int threads) {
    if (small.u.empty()) return {};
    const int w = small.width(), h = small.height();
    require(width >= w && height >= h, ErrorCode::InvalidArgument, "upscale_field: target smaller than the field");
    // Every pixel of every plane is written below (zeros where nothing is valid).
    SceneFlowField out = SceneFlowField::uninitialized(width, height);
    const float rx = float(width) / w, ry = float(height) / h;
    const cv::Mat1f *in[5] = {&small.u, &small.v, &small.d0, &small.d1, &small.confidence};
    cv::Mat1f *res[5] = {&out.u, &out.v, &out.d0, &out.d1, &out.confidence};
    const float gain[5] = {rx, ry, rx, rx, 1.0f};
    const EdgeGuide *guide = edges && edges->step > 0 ? edges : nullptr;
    if (guide)
        require(edges->small.size() == small.d0.size() && edges->full.size() == cv::Size(width, height),
                ErrorCode::SizeMismatch, "upscale_field: the edge guide's images differ in size from the fields");
    // The source columns and weight of each target column, the same for every row.
    std::vector<int> col0(width), col1(width), coln(width);
    std::vector<float> colw(width);
    for (int x = 0; x < width; ++x) {
        const float fx = std::clamp((x + 0.5f) / rx - 0.5f, 0.0f, float(w - 1));
        col0[x] = std::min(std::max(0, w - 2), static_cast<int>(fx));
        col1[x] = std::min(w - 1, col0[x] + 1);
        colw[x] = fx - col0[x];
        coln[x] = std::min(w - 1, static_cast<int>(x / rx));
    }
    // Each cell's kind once: target pixels share their four source corners with ~1 / scale^2
    // others.
    cv::Mat_<uint8_t> kind(h, w);
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y0 = 0; y0 < h; ++y0) {
        const int y1 = std::min(h - 1, y0 + 1);
        for (int x0 = 0; x0 < w; ++x0) kind(y0, x0) = cell_kind(small, guide, x0, std::min(w - 1, x0 + 1), y0, y1);
    }
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y = 0; y < height; ++y) {
        const float fy = std::clamp((y + 0.5f) / ry - 0.5f, 0.0f, float(h - 1));
        const int y0 = std::min(std::max(0, h - 2), static_cast<int>(fy)), y1 = std::min(h - 1, y0 + 1);
        const float ay = fy - y0;
        const int yn = std::min(h - 1, static_cast<int>(y / ry));
        // Row pointers: the planes' rows y0, y1 and yn, and the output row.
        const float *a[5], *b[5], *n[5];
        float *o[5];
        for (int c = 0; c < 5; ++c) {
            a[c] = in[c]->ptr<float>(y0), b[c] = in[c]->ptr<float>(y1), n[c] = in[c]->ptr<float>(yn);
            o[c] = res[c]->ptr<float>(y);
        }
        const uint8_t *kinds = kind.ptr<uint8_t>(y0), *valid_n = small.valid.ptr<uint8_t>(yn);
        uint8_t *valid = out.valid.ptr<uint8_t>(y);
        for (int x = 0; x < width; ++x) {
            const int x0 = col0[x], x1 = col1[x];
            const float ax = colw[x];
            const uint8_t k = kinds[x0];  // x1, y1: the next source pixel, as `kind` took them
            if (k == kBlend) {
                for (int c = 0; c < 5; ++c) {
                    const float top = a[c][x0] + ax * (a[c][x1] - a[c][x0]);
                    const float bot = b[c][x0] + ax * (b[c][x1] - b[c][x0]);
                    o[c][x] = gain[c] * (top + ay * (bot - top));
                }
                valid[x] = 1;
            } else if (k == kAtEdge) {
                const int corner = edge_corner(*guide, x, y, x0, x1, y0, y1);
                const float *const *src = corner < 2 ? a : b;
                const int xs = corner % 2 ? x1 : x0;
                for (int c = 0; c < 5; ++c) o[c][x] = gain[c] * src[c][xs];
                valid[x] = 1;
            } else {
                const int xn = coln[x];
                const bool near = valid_n[xn] != 0;
                for (int c = 0; c < 5; ++c) o[c][x] = near ? gain[c] * n[c][xn] : 0.0f;
                valid[x] = near ? 1 : 0;
            }
        }
    }
    return out;
}

void restore_lidar_d0(SceneFlowField &field, const SparseLidar &lidar0) {
    if (field.u.empty()) return;
    for (const LidarPoint &p : lidar0.points) {
        require(p.x >= 0 && p.y >= 0 && p.x < field.width() && p.y < field.height(), ErrorCode::InvalidArgument,
                "restore_lidar_d0: point outside the field");
        if (field.valid(p.y, p.x)) field.d0(p.y, p.x) = p.disparity;
    }
}

}  // namespace lidarflow::pipeline
