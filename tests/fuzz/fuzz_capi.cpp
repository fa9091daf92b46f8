// SPDX-License-Identifier: MIT
// The C ABI (liblidarflow, public header only) driven by the fuzz bytes as a program of calls:
// options with odd keys and values, calibrations, create, pushes of small images with odd
// sizes, strides and formats and LiDAR of every kind, every result call with odd buffers, out of
// order, then destroy. The format is in capi_program.hpp.
//
// Beyond crashes (ASan, UBSan, leaks) it checks what the header promises: status codes are
// known and never LF_ERR_INTERNAL, a failed call leaves a message and a successful one none,
// results have the size of the pushed frames, valid is 0/1 with zeros elsewhere, and the
// planes of views can be read whole.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

#include "capi_program.hpp"
#include "lidarflow/lidarflow.h"

namespace {

using namespace lidarflow::fuzz;

template <class T, size_t N>
constexpr size_t count_of(const T (&)[N]) {
    return N;
}

class Program {
public:
    Program(const uint8_t *data, size_t size) : p_(data), n_(size) {}
    bool done() const { return n_ == 0; }
    uint8_t u8() {
        if (n_ == 0) return 0;
        --n_;
        return *p_++;
    }
    float raw_float() {
        uint32_t u = 0;
        for (int i = 0; i < 4; ++i) u = (u << 8) | u8();
        float f;
        std::memcpy(&f, &u, 4);
        return f;
    }
    int64_t int_value() {
        const uint8_t i = u8();
        return i < count_of(kInts) ? kInts[i] : static_cast<int8_t>(u8());
    }
    double float_value() {
        const uint8_t i = u8();
        const size_t n = count_of(kFloats);
        if (i < n) return kFloats[i];
        if (i == n) return std::numeric_limits<double>::quiet_NaN();
        if (i == n + 1) return std::numeric_limits<double>::infinity();
        if (i == n + 2) return -std::numeric_limits<double>::infinity();
        if (i == n + 3) return std::numeric_limits<double>::denorm_min();
        return static_cast<int8_t>(u8()) / 4.0;
    }
    const char *key() { return kKeys[u8() % count_of(kKeys)]; }
    const char *string_value() { return kStrings[u8() % count_of(kStrings)]; }

private:
    const uint8_t *p_;
    size_t n_;
};

[[noreturn]] void fail(const char *what, int32_t rc, const char *message) {
    std::fprintf(stderr, "fuzz_capi: %s (status %d: %s)\n", what, rc, message ? message : "(null)");
    std::abort();
}

// A status is one the header names, never "a bug in lidarflow", and comes with a message
// exactly when it is an error.
void check_status(int32_t rc, const char *message, const char *call) {
    // FUZZ_CAPI_TRACE=1 prints every call: what a seed or a finding actually does.
    static const bool trace = std::getenv("FUZZ_CAPI_TRACE") != nullptr;
    if (trace) std::fprintf(stderr, "  %s -> %d %s\n", call, rc, message ? message : "(null)");
    switch (rc) {  // exactly the lf_status_t values of the header, each with its own text
    case LF_OK:
    case LF_ERR_INVALID_ARGUMENT:
    case LF_ERR_SIZE_MISMATCH:
    case LF_ERR_IO:
    case LF_ERR_FORMAT:
    case LF_ERR_BAD_STATE:
    case LF_ERR_NOT_READY:
    case LF_ERR_OUT_OF_MEMORY: break;
    case LF_ERR_INTERNAL: fail(call, rc, message);
    default: fail(call, rc, "not an lf_status_t value");
    }
    if (std::strcmp(lf_status_string(rc), lf_status_string(-1)) == 0) fail(call, rc, "status without a description");
    if (!message) fail(call, rc, "NULL last error");
    if ((rc == LF_OK) != (message[0] == '\0')) fail(call, rc, message);
}

uint8_t texture(int x, int y, uint8_t seed) {
    uint32_t h = static_cast<uint32_t>(x / 2 + 4096) * 374761393u + static_cast<uint32_t>(y / 2 + 4096) * 668265263u +
                 seed * 2246822519u;
    h = (h ^ (h >> 13)) * 1274126177u;
    return static_cast<uint8_t>(h >> 24);
}

// One pushed frame's images, allocated to their last byte so that ASan sees any read beyond.
struct Image {
    std::vector<uint8_t> bytes;
    lf_image_t view{};
};

int bytes_per_pixel(int32_t format) { return format == LF_PIXEL_GRAY8 ? 1 : 3; }

Image make_image(uint32_t w, uint32_t h, int32_t format, int stride_mode, uint8_t pad, int shift, uint8_t seed) {
    const uint64_t row = static_cast<uint64_t>(w) * bytes_per_pixel(format);
    uint64_t stride = row;
    if (stride_mode == 1) stride = row + pad % 8;
    if (stride_mode == 2) stride = row - 1;
    if (stride_mode == 3) stride = 0;
    Image im;
    // The rows the library may read: (h - 1) strides and one row, or one row if stride < row.
    const uint64_t size = (stride >= row ? stride * (h - 1) : 0) + row;
    im.bytes.resize(size);
    if (stride >= row)
        for (uint32_t y = 0; y < h; ++y)
            for (uint64_t b = 0; b < row; ++b) {
                const int x = static_cast<int>(b / bytes_per_pixel(format));
                im.bytes[y * stride + b] = static_cast<uint8_t>(texture(x + shift, static_cast<int>(y), seed) + 7 * (b % 3));
            }
    im.view = {im.bytes.data(), w, h, stride, format};
    return im;
}

// FUZZ_CAPI_STATS=1: how far the programs get, printed every 1000 programs and at exit.
// A program counts once, under the furthest stage of any result it produced (a full result:
// the interpolation's, i.e. two frames through every stage).
struct Stats {
    bool on = std::getenv("FUZZ_CAPI_STATS") != nullptr;
    uint64_t programs = 0, pushes = 0, pushes_ok = 0, results = 0;
    uint64_t by_stage[5] = {};  // 0: no result; else lf_stage_t
    void print() const {
        std::fprintf(stderr,
                     "fuzz_capi stats: %llu programs, %llu pushes (%llu ok, %llu with a result); programs by furthest "
                     "result: none %llu, matching %llu, consistency %llu, sparse %llu, full %llu (%.1f %%)\n",
                     (unsigned long long)programs, (unsigned long long)pushes, (unsigned long long)pushes_ok,
                     (unsigned long long)results, (unsigned long long)by_stage[0], (unsigned long long)by_stage[1],
                     (unsigned long long)by_stage[2], (unsigned long long)by_stage[3], (unsigned long long)by_stage[4],
                     programs ? 100.0 * by_stage[4] / programs : 0.0);
    }
};

Stats &stats() {
    static Stats *s = [] {
        auto *p = new Stats;
        if (p->on) std::atexit([] { stats().print(); });
        return p;
    }();
    return *s;
}

struct Session {
    lf_options_t *options = nullptr;
    lf_calibration_t calibration{};
    bool null_calibration = false;
    bool null_options = false;
    lf_estimator_t *est = nullptr;
    uint32_t width = 0, height = 0;  // of the frames since the last reset (0: none)
    int64_t timestamp = 0;
    int shift = 0;  // total motion of the scene [px]
    int furthest_stage = 0;  // of any result so far (Stats)

    void create() {
        const int32_t rc = lf_create(null_options ? nullptr : options, null_calibration ? nullptr : &calibration, &est);
        check_status(rc, rc == LF_OK ? "" : lf_last_error(nullptr), "lf_create");
        if ((rc == LF_OK) != (est != nullptr)) fail("lf_create: handle and status disagree", rc, "");
        width = height = 0;
    }
};

void options_op(Program &in, lf_options_t *opt) {
    const uint8_t kind = in.u8() % 7;
    const char *key = in.key();
    int32_t rc = LF_OK;
    switch (kind) {
    case 0: rc = lf_options_set_int(opt, key, in.int_value()); break;
    case 1: rc = lf_options_set_float(opt, key, in.float_value()); break;
    case 2: rc = lf_options_set_string(opt, key, in.string_value()); break;
    case 3: {
        int64_t v = 0;
        rc = lf_options_get_int(opt, key, &v);
        break;
    }
    case 4: {
        double v = 0;
        rc = lf_options_get_float(opt, key, &v);
        if (rc == LF_OK && std::isnan(v)) fail("lf_options_get_float: NaN option", rc, key);
        break;
    }
    case 5: {
        const char *v = nullptr;
        rc = lf_options_get_string(opt, key, &v);
        if (rc == LF_OK && !v) fail("lf_options_get_string: NULL value", rc, key);
        break;
    }
    default:
        rc = lf_options_set_int(nullptr, key, 1);
        if (rc != LF_ERR_INVALID_ARGUMENT) fail("lf_options_set_int(NULL)", rc, "");
        rc = lf_options_set_string(opt, key, nullptr);
        if (rc != LF_ERR_INVALID_ARGUMENT) fail("lf_options_set_string(value NULL)", rc, "");
    }
    check_status(rc, lf_options_last_error(opt), "options");
}

void calibration_op(Program &in, Session &s) {
    const uint8_t mode = in.u8() % 12;
    const double fx = 20 + in.u8(), baseline = 0.05 + in.u8() / 256.0;
    lf_calibration_t &c = s.calibration;
    lf_calibration_init(&c);
    c.fx = c.fy = fx;
    c.cx = 16;
    c.cy = 12;
    c.baseline = baseline;
    if (mode < 8 && mode % 2 == 1) {
        c.has_lidar_to_camera = 1;
        // LiDAR x forward, y left, z up -> camera x right, y down, z forward; 0.3 m behind.
        const double T[16] = {0, -1, 0, 0, 0, 0, -1, 0, 1, 0, 0, -0.3, 0, 0, 0, 1};
        std::memcpy(c.lidar_to_camera, T, sizeof T);
    }
    if (mode == 8) c.fx = std::numeric_limits<double>::quiet_NaN();
    if (mode == 9) c.baseline = 0;
    if (mode == 10) c.struct_size = 4;
    s.null_calibration = mode == 11;
}

// A plausible value of entry i for `kind` in a frame of w x h with disparity d [px].
void consistent_entry(int32_t kind, uint32_t i, uint32_t w, uint32_t h, float d, const lf_calibration_t &c,
                      float out[3]) {
    const float x = static_cast<float>((i * 7u) % w), y = static_cast<float>((i * 5u) % h);
    const double z = d > 0 ? c.fx * c.baseline / d : 50.0;
    const double X = (x - c.cx) * z / c.fx, Y = (y - c.cy) * z / c.fy;
    if (kind == LF_LIDAR_DISPARITY) {
        out[0] = x;
        out[1] = y;
        out[2] = d;
    } else if (kind == LF_LIDAR_POINTS_LIDAR) {  // inverse of the calibration's transform
        out[0] = static_cast<float>(z + 0.3);
        out[1] = static_cast<float>(-X);
        out[2] = static_cast<float>(-Y);
    } else {
        out[0] = static_cast<float>(X);
        out[1] = static_cast<float>(Y);
        out[2] = static_cast<float>(z);
    }
}

void push_op(Program &in, Session &s) {
    const uint32_t w = 1 + in.u8() % 64, h = 1 + in.u8() % 48;
    const int32_t format = in.u8() % 5;
    const int stride_mode = in.u8() % 4;
    const uint8_t pad = in.u8();
    const uint8_t flags = in.u8();
    const int motion = static_cast<int8_t>(in.u8());
    const float disparity = static_cast<float>(in.u8() % 16);
    const uint8_t seed = in.u8();
    const int64_t dt = static_cast<int8_t>(in.u8()) * INT64_C(1000);
    const uint8_t lidar_kind = in.u8() % 6;
    const uint32_t count = in.u8() % 32;
    const uint8_t stride_sel = in.u8() % 4;
    const uint64_t lidar_stride = stride_sel == 0 ? 0 : stride_sel == 1 ? 12 : stride_sel == 2 ? 16 : in.u8() % 12;
    const uint8_t values = in.u8() % 4;

    const int32_t valid_format = format >= 1 && format <= 3 ? format : LF_PIXEL_GRAY8;
    const int32_t right_format = (flags & 4) ? (valid_format % 3) + 1 : format;
    const int shift = s.shift + motion;
    const int d = static_cast<int>(disparity);
    Image left = make_image(w, h, valid_format, stride_mode, pad, -shift, seed);
    left.view.format = format;
    Image right = make_image(w + (flags & 1), h, right_format >= 1 && right_format <= 3 ? right_format : 1,
                             stride_mode, pad, d - shift, seed);
    right.view.format = right_format;
    if (flags & 2) left.view.data = nullptr;

    lf_lidar_t lidar{};
    std::vector<uint8_t> entries;
    const int32_t kinds[6] = {LF_LIDAR_NONE, LF_LIDAR_NONE, LF_LIDAR_POINTS_CAMERA, LF_LIDAR_POINTS_LIDAR,
                              LF_LIDAR_DISPARITY, 7};
    lidar.kind = kinds[lidar_kind];
    lidar.count = count;
    lidar.stride_bytes = lidar_stride;
    const uint64_t element = lidar_stride == 0 ? 12 : lidar_stride;
    if (count > 0) entries.resize((count - 1) * element + 12);  // the last entry's 3 floats end the buffer
    for (uint32_t i = 0; i < count; ++i) {
        float e[3];
        if (values == 1) {
            for (float &v : e) v = in.raw_float();
        } else if (values == 2) {
            for (float &v : e) v = static_cast<float>(in.float_value());
        } else {
            consistent_entry(lidar.kind, i, w, h, disparity, s.calibration, e);
        }
        std::memcpy(entries.data() + i * element, e, sizeof e);
    }
    lidar.data = values == 3 || entries.empty() ? nullptr : entries.data();

    s.timestamp += dt;
    const int32_t rc = lf_push_frame(s.est, s.timestamp, &left.view, &right.view, lidar_kind == 0 ? nullptr : &lidar);
    check_status(rc, lf_last_error(s.est), "lf_push_frame");
    static const bool trace = std::getenv("FUZZ_CAPI_TRACE") != nullptr;
    lf_result_info_t info;
    lf_result_info_init(&info);
    Stats &st = stats();
    if (st.on) {
        ++st.pushes;
        st.pushes_ok += rc == LF_OK;
        if (rc == LF_OK && lf_get_result_info(s.est, &info) == LF_OK) {
            ++st.results;
            s.furthest_stage = std::max<int>(s.furthest_stage, info.last_stage);
        }
    }
    if (trace && rc == LF_OK && lf_get_result_info(s.est, &info) == LF_OK) {
        std::vector<uint8_t> valid(static_cast<size_t>(w) * h);
        lf_result_buffers_t b;
        lf_result_buffers_init(&b);
        b.width = w;
        b.height = h;
        b.valid = {valid.data(), w};
        if (lf_get_result(s.est, &b) == LF_OK)
            std::fprintf(stderr, "    result of stage %d: %d of %u px valid\n", info.last_stage,
                         static_cast<int>(std::count(valid.begin(), valid.end(), 1)), w * h);
        for (uint32_t i = 0; i < info.timing_count; ++i) {
            const char *name = nullptr;
            double seconds = 0;
            lf_get_timing(s.est, i, &name, &seconds);
            std::fprintf(stderr, "    %s %.1f ms\n", name, 1e3 * seconds);
        }
    }
    if (rc == LF_OK) {
        if (s.width != 0 && (s.width != w || s.height != h)) fail("lf_push_frame accepted another size", rc, "");
        s.width = w;
        s.height = h;
        s.shift = shift;
    }
}

// valid is 0/1; where 0, the values are 0; where 1, they are finite (confidence >= 0).
void check_plane_values(const uint8_t *valid, const float *const planes[5], size_t n, const char *call) {
    for (size_t i = 0; i < n; ++i) {
        if (valid[i] > 1) fail(call, 0, "valid is neither 0 nor 1");
        for (int k = 0; k < 5; ++k) {
            const float v = planes[k][i];
            // Holes: NaN in u, v, d0, d1 (k < 4), 0 confidence.
            if (!valid[i] && (k < 4 ? !std::isnan(v) : v != 0)) fail(call, 0, "hole is neither NaN nor 0 confidence");
            if (valid[i] && !std::isfinite(v)) fail(call, 0, "non-finite value where valid");
        }
        if (planes[4][i] < 0) fail(call, 0, "negative confidence");
    }
}

void info_op(Program &in, Session &s) {
    // A newer caller's struct may be larger (its tail zeroed): give the library those bytes.
    struct {
        lf_result_info_t info;
        uint8_t tail[64];
    } storage{};
    lf_result_info_t &info = storage.info;
    lf_result_info_init(&info);
    const uint8_t mode = in.u8() % 3;
    if (mode == 1) info.struct_size = 4;
    if (mode == 2) info.struct_size += sizeof storage.tail;
    const int32_t rc = lf_get_result_info(s.est, &info);
    check_status(rc, lf_last_error(s.est), "lf_get_result_info");
    if (rc == LF_OK) {
        if (!lf_has_result(s.est)) fail("lf_get_result_info without a result", rc, "");
        if (info.width != s.width || info.height != s.height) fail("result size differs from the frames'", rc, "");
        if (info.last_stage < LF_STAGE_MATCHING || info.last_stage > LF_STAGE_INTERPOLATION)
            fail("unknown last_stage", info.last_stage, "");
        if (info.t1_us <= info.t0_us || !(info.total_seconds >= 0) || !std::isfinite(info.total_seconds))
            fail("result times", rc, "");
    }
}

void timing_op(Program &in, Session &s) {
    const uint8_t index = in.u8(), mask = in.u8();
    const char *name = nullptr;
    double seconds = -1;
    const int32_t rc = lf_get_timing(s.est, index == 255 ? UINT32_MAX : index, (mask & 1) ? nullptr : &name,
                                     (mask & 2) ? nullptr : &seconds);
    check_status(rc, lf_last_error(s.est), "lf_get_timing");
    if (rc == LF_OK &&
        (((mask & 1) == 0 && (!name || !name[0])) || ((mask & 2) == 0 && !(seconds >= 0 && std::isfinite(seconds)))))
        fail("lf_get_timing: empty name or negative time", rc, "");
}

void result_op(Program &in, Session &s) {
    const uint8_t mask = in.u8();
    const int delta = in.u8() % 3 - 1;
    const uint8_t stride_mode = in.u8() % 3;
    // At least 1 px wide: the harness's own stride arithmetic must not wrap.
    const uint32_t w = s.width ? std::max<int64_t>(1, int64_t(s.width) + delta) : 1 + (delta + 1),
                   h = s.height ? s.height : 1;
    const uint64_t pad = stride_mode == 1 ? 4 : 0;
    std::vector<float> planes[6];
    std::vector<uint8_t> valid;
    lf_result_buffers_t b;
    lf_result_buffers_init(&b);
    b.width = w;
    b.height = h;
    lf_plane_t *out[6] = {&b.u, &b.v, &b.d0, &b.d1, &b.confidence, &b.valid};
    for (int k = 0; k < 6; ++k) {
        if (!(mask & (1u << k))) continue;
        const uint64_t elem = k == 5 ? 1 : 4;
        uint64_t stride = w * elem + pad;
        if (stride_mode == 2) stride -= elem;
        const size_t bytes = stride * (h - 1) + w * elem;
        if (k == 5) {
            valid.assign(bytes, 0xAB);
            out[k]->data = valid.data();
        } else {
            planes[k].assign((bytes + 3) / 4, -7.0f);
            out[k]->data = planes[k].data();
        }
        out[k]->stride_bytes = stride;
    }
    const int32_t rc = lf_get_result(s.est, &b);
    check_status(rc, lf_last_error(s.est), "lf_get_result");
    if (rc == LF_OK && (mask & 0x3F) == 0x3F && pad == 0) {
        const float *p[5] = {planes[0].data(), planes[1].data(), planes[2].data(), planes[3].data(), planes[4].data()};
        check_plane_values(valid.data(), p, static_cast<size_t>(w) * h, "lf_get_result");
    }
}

void views_op(Session &s) {
    lf_result_views_t v;
    lf_result_views_init(&v);
    const int32_t rc = lf_get_result_views(s.est, &v);
    check_status(rc, lf_last_error(s.est), "lf_get_result_views");
    if (rc != LF_OK) return;
    if (v.width != s.width || v.height != s.height) fail("views size differs from the frames'", rc, "");
    const lf_view_t *views[5] = {&v.u, &v.v, &v.d0, &v.d1, &v.confidence};
    std::vector<float> planes[5];
    std::vector<uint8_t> valid(static_cast<size_t>(v.width) * v.height);
    for (uint32_t y = 0; y < v.height; ++y) {
        for (int k = 0; k < 5; ++k) {
            planes[k].resize(valid.size());
            std::memcpy(&planes[k][y * v.width], static_cast<const uint8_t *>(views[k]->data) + y * views[k]->stride_bytes,
                        4 * v.width);
        }
        std::memcpy(&valid[y * v.width], static_cast<const uint8_t *>(v.valid.data) + y * v.valid.stride_bytes, v.width);
    }
    const float *p[5] = {planes[0].data(), planes[1].data(), planes[2].data(), planes[3].data(), planes[4].data()};
    check_plane_values(valid.data(), p, valid.size(), "lf_get_result_views");
}

void points_op(Program &in, Session &s) {
    const uint8_t mask = in.u8();
    const int delta = in.u8() % 3 - 1;
    const uint8_t stride_mode = in.u8() % 3;
    const uint32_t w = s.width ? std::max<int64_t>(1, int64_t(s.width) + delta) : 1, h = s.height ? s.height : 1;
    lf_points3d_buffers_t b;
    lf_points3d_buffers_init(&b);
    b.width = w;
    b.height = h;
    std::vector<uint8_t> bufs[3];
    lf_plane_t *out[3] = {&b.points, &b.motion, &b.valid};
    for (int k = 0; k < 3; ++k) {
        if (!(mask & (1u << k))) continue;
        const uint64_t elem = k == 2 ? 1 : 12;
        uint64_t stride = w * elem + (stride_mode == 1 ? 4 : 0);
        if (stride_mode == 2) stride -= 1;
        bufs[k].assign(stride * (h - 1) + w * elem, 0xCD);
        out[k]->data = bufs[k].data();
        out[k]->stride_bytes = stride;
    }
    const int32_t rc = lf_get_points3d(s.est, &b);
    check_status(rc, lf_last_error(s.est), "lf_get_points3d");
    if (rc == LF_OK && (mask & 7) == 7 && stride_mode == 0) {
        // The result the points come from: a valid point has a valid result with d0, d1 > 0
        // and z = fx * baseline / d0.
        const size_t n = static_cast<size_t>(w) * h;
        std::vector<float> d0(n);
        std::vector<uint8_t> valid_result(n);
        lf_result_buffers_t r;
        lf_result_buffers_init(&r);
        r.width = w;
        r.height = h;
        r.d0 = {d0.data(), 4 * uint64_t(w)};
        r.valid = {valid_result.data(), w};
        const int32_t rc_result = lf_get_result(s.est, &r);
        check_status(rc_result, lf_last_error(s.est), "lf_get_result (for lf_get_points3d)");
        if (rc_result != LF_OK) fail("lf_get_points3d succeeded where lf_get_result failed", rc_result, "");
        for (size_t i = 0; i < n; ++i) {
            if (bufs[2][i] != 1) continue;
            if (!valid_result[i] || !(d0[i] > 0)) fail("lf_get_points3d: a valid point where d0 is not", rc, "");
            float z;
            std::memcpy(&z, &bufs[0][12 * i + 8], 4);
            const double expected = s.calibration.fx * s.calibration.baseline / d0[i];
            if (!(std::fabs(z - expected) <= 1e-4 * expected)) fail("lf_get_points3d: z != fx * baseline / d0", rc, "");
        }
        for (size_t i = 0; i < n; ++i) {
            const uint8_t valid = bufs[2][i];
            if (valid > 1) fail("lf_get_points3d: valid is neither 0 nor 1", rc, "");
            float pm[6];
            std::memcpy(pm, &bufs[0][12 * i], 12);
            std::memcpy(pm + 3, &bufs[1][12 * i], 12);
            // The header: invalid points are NaN; a valid one is finite (non-finite points,
            // e.g. the depth of a tiny disparity, are marked invalid).
            for (float f : pm)
                if (valid ? !std::isfinite(f) : !std::isnan(f))
                    fail("lf_get_points3d: non-finite where valid or not NaN where not", rc, "");
        }
    }

    // The ego-motion of the same result, and the object motion into the same planes' layout.
    lf_ego_motion_t ego;
    lf_ego_motion_init(&ego);
    const int32_t rc_ego = lf_get_ego_motion(s.est, &ego);
    check_status(rc_ego, lf_last_error(s.est), "lf_get_ego_motion");
    if (rc_ego == LF_OK) {
        if (ego.state < LF_EGO_OK || ego.state > LF_EGO_DISABLED) fail("lf_get_ego_motion: unknown state", rc_ego, "");
        if (ego.inliers > ego.candidates) fail("lf_get_ego_motion: more inliers than candidates", rc_ego, "");
        for (int k = 0; k < 16; ++k) {
            const double t = ego.transform[k];
            if (!std::isfinite(t) || (k >= 12 && t != (k == 15 ? 1.0 : 0.0)) ||
                (ego.state != LF_EGO_OK && t != (k % 5 == 0 ? 1.0 : 0.0)))
                fail("lf_get_ego_motion: transform not finite, last row not 0 0 0 1, or not the identity "
                     "without a fit",
                     rc_ego, "");
        }
    }
    lf_object_motion_buffers_t o;
    lf_object_motion_buffers_init(&o);
    o.width = w;
    o.height = h;
    std::vector<uint8_t> om(bufs[1].size(), 0xCD), om_valid(bufs[2].size(), 0xCD);
    if (mask & 2u) o.motion = {om.data(), b.motion.stride_bytes};
    if (mask & 4u) o.valid = {om_valid.data(), b.valid.stride_bytes};
    const int32_t rc_om = lf_get_object_motion(s.est, &o);
    check_status(rc_om, lf_last_error(s.est), "lf_get_object_motion");
    if (rc_om == LF_OK && (rc_ego != LF_OK || ego.state != LF_EGO_OK))
        fail("lf_get_object_motion succeeded without an ego-motion", rc_om, "");
    if (rc_om == LF_OK && rc == LF_OK && (mask & 6) == 6 && stride_mode == 0) {
        // Valid only where lf_get_points3d is (the same triangulation); finite there, NaN elsewhere.
        for (size_t i = 0; i < om_valid.size(); ++i) {
            if (om_valid[i] > bufs[2][i]) fail("lf_get_object_motion: valid where lf_get_points3d is not", rc_om, "");
            float m[3];
            std::memcpy(m, &om[12 * i], 12);
            for (float f : m)
                if (om_valid[i] ? !std::isfinite(f) : !std::isnan(f))
                    fail("lf_get_object_motion: non-finite where valid or not NaN where not", rc_om, "");
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    Program in(data, size);
    Session s;
    if (lf_options_create(&s.options) != LF_OK) fail("lf_options_create", -1, lf_last_error(nullptr));
    // Cheap settings first (the program may override them): one thread, few levels, few
    // iterations, so that two-frame results come hundreds of times per second.
    const struct {
        const char *key;
        int64_t value;
    } cheap[] = {{"matching.max_levels", 2}, {"matching.min_coarsest_height", 8}, {"matching.iterations", 2},
                 {"consistency.sgm_num_disparities", 16}, {"interpolation.iterations", 2},
                 {"interpolation.superpixel_size", 8}, {"consistency.cluster_min_size", 4}};
    for (const auto &c : cheap)
        if (lf_options_set_int(s.options, c.key, c.value) != LF_OK)
            fail("cheap option refused", -1, lf_options_last_error(s.options));
    // Search ranges that fit the frames (at most 64x48 px, disparities < 16 px): with the
    // defaults (flow 400 px, disparity 256 px) the random initialisation puts most matches
    // outside such small images, the forward-backward check keeps none and frames below
    // ~64x48 never reach the interpolation.
    if (lf_options_set_float(s.options, "matching.max_flow", 16) != LF_OK ||
        lf_options_set_float(s.options, "matching.max_disparity", 32) != LF_OK)
        fail("cheap option refused", -1, lf_options_last_error(s.options));
    const int n_options = in.u8() % 16;
    for (int i = 0; i < n_options; ++i) options_op(in, s.options);
    // OpenMP teams are slow under ASan and would make runs depend on scheduling.
    if (lf_options_set_int(s.options, "threads", 1) != LF_OK) fail("threads=1 refused", -1, "");

    calibration_op(in, s);
    s.null_options = in.u8() & 1;
    s.create();
    for (int op = 0; op < kMaxOps && !in.done(); ++op) {
        if (!s.est) {  // every call on a missing handle fails cleanly
            lf_result_views_t v;
            lf_result_views_init(&v);
            if (lf_push_frame(nullptr, 0, nullptr, nullptr, nullptr) != LF_ERR_INVALID_ARGUMENT ||
                lf_get_result_views(nullptr, &v) != LF_ERR_INVALID_ARGUMENT || lf_has_result(nullptr) != 0 ||
                lf_reset(nullptr) != LF_ERR_INVALID_ARGUMENT)
                fail("a call on a NULL handle", -1, "");
            break;
        }
        switch (in.u8() % kOpCount) {
        case kPush: push_op(in, s); break;
        case kReset:
            check_status(lf_reset(s.est), lf_last_error(s.est), "lf_reset");
            s.width = s.height = 0;
            break;
        case kHasResult:
            if (lf_has_result(s.est) && s.width == 0) fail("a result after a reset", -1, "");
            break;
        case kInfo: info_op(in, s); break;
        case kTiming: timing_op(in, s); break;
        case kResult: result_op(in, s); break;
        case kViews: views_op(s); break;
        case kPoints: points_op(in, s); break;
        case kRecreate:
            lf_destroy(s.est);
            s.est = nullptr;
            s.create();
            break;
        default: {
            const char *text = lf_status_string(static_cast<int8_t>(in.u8()));
            if (!text || !text[0]) fail("lf_status_string", -1, "");
        }
        }
    }
    lf_destroy(s.est);
    lf_options_destroy(s.options);
    Stats &st = stats();
    if (st.on) {
        ++st.programs;
        ++st.by_stage[s.furthest_stage >= 1 && s.furthest_stage <= 4 ? s.furthest_stage : 0];
        if (st.programs % 1000 == 0) st.print();
    }
    return 0;
}
