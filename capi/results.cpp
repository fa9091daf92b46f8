// SPDX-License-Identifier: MIT
// Result queries of the C ABI: info, timings, copies into caller planes, borrowed views and
// the 3-D (metric) form. Every argument is checked before the first byte is written.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <initializer_list>
#include <tuple>
#include <vector>

#include "core/points3d.hpp"
#include "guard.hpp"
#include "handles.hpp"

using lidarflow::ErrorCode;
using lidarflow::require;
using namespace lidarflow::capi;

namespace {

const Result &ready_result(const lf_estimator_t *h) {
    require_non_null(h, "estimator");
    // The owner's thread may replace the result meanwhile.
    require(pair_owner != h, ErrorCode::BadState,
            "the estimator's result cannot be read from the log callback of one of its frame workers");
    if (!h->result && h->pair_error) std::rethrow_exception(h->pair_error);
    require(h->result != nullptr, ErrorCode::NotReady, [&] {
        if (h->pool && h->pool->in_flight() > 0)
            return "no result yet: " + std::to_string(h->pool->in_flight()) +
                   " pair(s) in flight, each handed over frames_in_flight - 1 pushes later or by lf_flush";
        return std::string(h->previous ? "no result yet: one frame pushed, the result comes with the second"
                                       : "no result yet: push two frames first");
    });
    return *h->result;
}

void check_buffer_size(uint32_t width, uint32_t height, const Result &r) {
    require(static_cast<int>(width) == r.field.u.cols && static_cast<int>(height) == r.field.u.rows,
            ErrorCode::SizeMismatch,
            "buffers are " + std::to_string(width) + "x" + std::to_string(height) + ", the result is " +
                std::to_string(r.field.u.cols) + "x" + std::to_string(r.field.u.rows));
}

void check_plane(const lf_plane_t &p, uint32_t width, size_t element_bytes, const char *name) {
    if (!p.data) return;
    const uint64_t row = static_cast<uint64_t>(width) * element_bytes;
    require(p.stride_bytes >= row, ErrorCode::SizeMismatch,
            std::string(name) + ".stride_bytes " + std::to_string(p.stride_bytes) + " is smaller than a row (" +
                std::to_string(row) + " bytes)");
}

// Row-wise copy of a continuous matrix into a caller plane (any alignment).
void copy_plane(const cv::Mat &m, const lf_plane_t &p) {
    if (!p.data) return;
    const size_t row = m.cols * m.elemSize();
    for (int y = 0; y < m.rows; ++y)
        std::memcpy(static_cast<unsigned char *>(p.data) + static_cast<uint64_t>(y) * p.stride_bytes, m.ptr(y), row);
}

lf_view_t view_of(const cv::Mat &m) { return {m.data, static_cast<uint64_t>(m.step[0])}; }

// Writes the library's fields of *dst (a caller struct already size-checked) from `src`,
// keeping the caller's struct_size and any newer fields it has.
template <class T>
void write_struct(T *dst, const T &src) {
    T tmp = src;
    tmp.struct_size = dst->struct_size;
    std::memcpy(dst, &tmp, sizeof(T));
}

// The per-pixel walk of lf_get_points3d and lf_get_object_motion: each pixel's triangulated
// scene point (ok = false where there is none) goes to `pixel(x, q, ok)`, which fills row
// buffers; `planes` (caller plane, row buffer, bytes per row) are copied out row by row.
template <typename PerPixel>
void walk_points(const Result &r, const lidarflow::StereoCamera &cam,
                 std::initializer_list<std::tuple<const lf_plane_t *, const void *, size_t>> planes, PerPixel pixel) {
    const int w = r.field.u.cols, h = r.field.u.rows;
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            lidarflow::ScenePoint3 q;
            const bool ok = r.field.valid(y, x) &&
                            lidarflow::triangulate_scene_flow(cam, x, y, r.field.u(y, x), r.field.v(y, x),
                                                              r.field.d0(y, x), r.field.d1(y, x), &q);
            pixel(x, q, ok);
        }
        for (const auto &[plane, row, bytes] : planes)
            if (plane->data)
                std::memcpy(static_cast<unsigned char *>(plane->data) + static_cast<uint64_t>(y) * plane->stride_bytes,
                            row, bytes);
    }
}

}  // namespace

extern "C" {

LF_API int32_t lf_get_result_info(lf_estimator_t *estimator, lf_result_info_t *info) {
    return guarded(sink_of(estimator), "lf_get_result_info", [&] {
        require_non_null(estimator, "estimator");
        require_non_null(info, "info");
        // The first layout (without the 0.2.0 fields) is still taken, and written only as far as it goes.
        const bool v1 = info->struct_size == LF_RESULT_INFO_V1_SIZE;
        if (!v1) check_struct_size(info, info->struct_size, sizeof(lf_result_info_t), "info");
        const Result &r = ready_result(estimator);
        lf_result_info_t out;
        std::memset(&out, 0, sizeof out);
        out.width = static_cast<uint32_t>(r.field.u.cols);
        out.height = static_cast<uint32_t>(r.field.u.rows);
        out.last_stage = static_cast<int32_t>(r.stage);
        out.t0_us = r.t0_us;
        out.t1_us = r.t1_us;
        out.timing_count = static_cast<uint32_t>(r.timings.size());
        out.total_seconds = r.total_seconds;
        out.rectified = r.rectified ? 1u : 0u;
        out.struct_size = info->struct_size;
        std::memcpy(info, &out, v1 ? LF_RESULT_INFO_V1_SIZE : sizeof out);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_get_timing(lf_estimator_t *estimator, uint32_t index, const char **name, double *seconds) {
    return guarded(sink_of(estimator), "lf_get_timing", [&] {
        const Result &r = ready_result(estimator);
        require(index < r.timings.size(), ErrorCode::InvalidArgument,
                "timing index " + std::to_string(index) + " out of range (" + std::to_string(r.timings.size()) +
                    " timings)");
        if (name) *name = r.timings[index].name.c_str();
        if (seconds) *seconds = r.timings[index].seconds;
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_get_result(lf_estimator_t *estimator, const lf_result_buffers_t *buffers) {
    return guarded(sink_of(estimator), "lf_get_result", [&] {
        require_non_null(estimator, "estimator");
        require_non_null(buffers, "buffers");
        check_struct_size(buffers, buffers->struct_size, sizeof(lf_result_buffers_t), "buffers");
        const Result &r = ready_result(estimator);
        const lf_result_buffers_t &b = *buffers;
        check_buffer_size(b.width, b.height, r);
        check_plane(b.u, b.width, sizeof(float), "u");
        check_plane(b.v, b.width, sizeof(float), "v");
        check_plane(b.d0, b.width, sizeof(float), "d0");
        check_plane(b.d1, b.width, sizeof(float), "d1");
        check_plane(b.valid, b.width, 1, "valid");
        check_plane(b.confidence, b.width, sizeof(float), "confidence");
        copy_plane(r.field.u, b.u);
        copy_plane(r.field.v, b.v);
        copy_plane(r.field.d0, b.d0);
        copy_plane(r.field.d1, b.d1);
        copy_plane(r.field.valid, b.valid);
        copy_plane(r.field.confidence, b.confidence);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_get_result_views(lf_estimator_t *estimator, lf_result_views_t *views) {
    return guarded(sink_of(estimator), "lf_get_result_views", [&] {
        require_non_null(estimator, "estimator");
        require_non_null(views, "views");
        check_struct_size(views, views->struct_size, sizeof(lf_result_views_t), "views");
        const Result &r = ready_result(estimator);
        lf_result_views_t out;
        std::memset(&out, 0, sizeof out);
        out.width = static_cast<uint32_t>(r.field.u.cols);
        out.height = static_cast<uint32_t>(r.field.u.rows);
        out.u = view_of(r.field.u);
        out.v = view_of(r.field.v);
        out.d0 = view_of(r.field.d0);
        out.d1 = view_of(r.field.d1);
        out.valid = view_of(r.field.valid);
        out.confidence = view_of(r.field.confidence);
        write_struct(views, out);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_get_points3d(lf_estimator_t *estimator, const lf_points3d_buffers_t *buffers) {
    return guarded(sink_of(estimator), "lf_get_points3d", [&] {
        require_non_null(estimator, "estimator");
        require_non_null(buffers, "buffers");
        check_struct_size(buffers, buffers->struct_size, sizeof(lf_points3d_buffers_t), "buffers");
        const Result &r = ready_result(estimator);
        const lf_points3d_buffers_t &b = *buffers;
        check_buffer_size(b.width, b.height, r);
        check_plane(b.points, b.width, 3 * sizeof(float), "points");
        check_plane(b.motion, b.width, 3 * sizeof(float), "motion");
        check_plane(b.valid, b.width, 1, "valid");

        const size_t w = static_cast<size_t>(r.field.u.cols);
        const float nan = std::numeric_limits<float>::quiet_NaN();
        std::vector<float> points(3 * w), motion(3 * w);
        std::vector<unsigned char> valid(w);
        walk_points(r, estimator->calibration.camera,
                    {{&b.points, points.data(), points.size() * sizeof(float)},
                     {&b.motion, motion.data(), motion.size() * sizeof(float)},
                     {&b.valid, valid.data(), valid.size()}},
                    [&](int x, const lidarflow::ScenePoint3 &q, bool ok) {
                        valid[x] = ok ? 1 : 0;
                        float *p = &points[3 * x], *m = &motion[3 * x];
                        if (!ok) {
                            p[0] = p[1] = p[2] = m[0] = m[1] = m[2] = nan;
                            return;
                        }
                        p[0] = static_cast<float>(q.x);
                        p[1] = static_cast<float>(q.y);
                        p[2] = static_cast<float>(q.z);
                        m[0] = static_cast<float>(q.dx);
                        m[1] = static_cast<float>(q.dy);
                        m[2] = static_cast<float>(q.dz);
                    });
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_get_ego_motion(lf_estimator_t *estimator, lf_ego_motion_t *ego) {
    return guarded(sink_of(estimator), "lf_get_ego_motion", [&] {
        require_non_null(estimator, "estimator");
        require_non_null(ego, "ego");
        check_struct_size(ego, ego->struct_size, sizeof(lf_ego_motion_t), "ego");
        const Result &r = ready_result(estimator);
        lf_ego_motion_t out;
        std::memset(&out, 0, sizeof out);
        out.state = static_cast<int32_t>(r.ego_state);
        for (int i = 0; i < 4; ++i) out.transform[5 * i] = 1.0;
        if (r.ego_state == lidarflow::pipeline::EgoState::Ok)
            for (int i = 0; i < 3; ++i) {
                for (int j = 0; j < 3; ++j) out.transform[4 * i + j] = r.ego.R[3 * i + j];
                out.transform[4 * i + 3] = r.ego.t[i];
            }
        out.inliers = static_cast<uint32_t>(std::max(0, r.ego.inliers));
        out.candidates = static_cast<uint32_t>(std::max(0, r.ego.candidates));
        write_struct(ego, out);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_get_quality(lf_estimator_t *estimator, uint32_t *flags, const char **reason) {
    return guarded(sink_of(estimator), "lf_get_quality", [&] {
        require_non_null(estimator, "estimator");
        const Result &r = ready_result(estimator);
        if (flags) *flags = r.quality.flags;
        if (reason) *reason = r.quality.reason.c_str();
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API const char *lf_quality_name(uint32_t flag) {
    return flag == 0 ? "ok" : lidarflow::quality::flag_name(flag);
}

LF_API int32_t lf_get_object_motion(lf_estimator_t *estimator, const lf_object_motion_buffers_t *buffers) {
    return guarded(sink_of(estimator), "lf_get_object_motion", [&] {
        require_non_null(estimator, "estimator");
        require_non_null(buffers, "buffers");
        check_struct_size(buffers, buffers->struct_size, sizeof(lf_object_motion_buffers_t), "buffers");
        const Result &r = ready_result(estimator);
        const lf_object_motion_buffers_t &b = *buffers;
        check_buffer_size(b.width, b.height, r);
        check_plane(b.motion, b.width, 3 * sizeof(float), "motion");
        check_plane(b.valid, b.width, 1, "valid");
        require(r.ego_state == lidarflow::pipeline::EgoState::Ok, ErrorCode::BadState,
                std::string("no object motion: the ego-motion is ") + lidarflow::pipeline::ego_state_text(r.ego_state));

        const size_t w = static_cast<size_t>(r.field.u.cols);
        const float nan = std::numeric_limits<float>::quiet_NaN();
        std::vector<float> motion(3 * w);
        std::vector<unsigned char> valid(w);
        walk_points(r, estimator->calibration.camera,
                    {{&b.motion, motion.data(), motion.size() * sizeof(float)}, {&b.valid, valid.data(), valid.size()}},
                    [&](int x, const lidarflow::ScenePoint3 &q, bool ok) {
                        double m[3] = {0, 0, 0};
                        if (ok) lidarflow::object_motion(q, r.ego.R, r.ego.t, m);
                        // Same validity as lf_get_points3d: every written value fits a float.
                        const bool fits = ok && std::fabs(m[0]) <= std::numeric_limits<float>::max() &&
                                          std::fabs(m[1]) <= std::numeric_limits<float>::max() &&
                                          std::fabs(m[2]) <= std::numeric_limits<float>::max();
                        valid[x] = fits ? 1 : 0;
                        for (int c = 0; c < 3; ++c) motion[3 * x + c] = fits ? static_cast<float>(m[c]) : nan;
                    });
        return static_cast<int32_t>(LF_OK);
    });
}

}  // extern "C"
