// SPDX-License-Identifier: MIT
#include "wire.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <limits>

#include "wire_detail.hpp"

namespace lidarflow::bridge {
namespace detail {

// LCM encodes integers big-endian.
int64_t read_be(const uint8_t *p, int bytes) {
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
    if (bytes < 8 && (v >> (8 * bytes - 1)) & 1u) v |= ~uint64_t(0) << (8 * bytes);  // sign-extend
    return static_cast<int64_t>(v);
}

void write_be(uint8_t *p, uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i, v >>= 8) p[i] = static_cast<uint8_t>(v);
}

int bytes_per_pixel(int8_t format) {
    switch (format) {
    case LIDARFLOW_STEREO_T_PIXEL_GRAY8: return 1;
    case LIDARFLOW_STEREO_T_PIXEL_RGB8:
    case LIDARFLOW_STEREO_T_PIXEL_BGR8: return 3;
    default: return 0;
    }
}

}  // namespace detail

using detail::bytes_per_pixel;
using detail::read_be;

namespace {

// lcm-gen's encoder of any message type: the bytes, empty when encoding failed.
template <typename Msg>
std::vector<uint8_t> encode_message(const Msg &msg, int (*encoded_size)(const Msg *),
                                    int (*encode)(void *, int, int, const Msg *)) {
    std::vector<uint8_t> buf(static_cast<size_t>(encoded_size(&msg)));
    const int n = encode(buf.data(), 0, static_cast<int>(buf.size()), &msg);
    buf.resize(n < 0 ? 0 : static_cast<size_t>(n));
    return buf;
}

// One length field of a message: its byte offset after the fingerprint and the bytes one unit
// of it adds to the message.
struct LengthField {
    const char *name;
    int offset;
    int64_t unit_bytes;
};

// Checks fingerprint, length fields and exact size of a message whose fixed part (everything
// but the arrays) is `fixed` bytes after the fingerprint. Returns "" or the problem.
std::string check_wire(const void *data, size_t size, const char *type, int64_t hash, int64_t fixed,
                       const std::vector<LengthField> &lengths) {
    const auto *p = static_cast<const uint8_t *>(data);
    // lcm-gen's decoders count bytes in int.
    if (size > static_cast<size_t>(std::numeric_limits<int>::max()))
        return printf_string("oversized: %zu bytes, a %s holds at most %d", size, type, std::numeric_limits<int>::max());
    if (size < 8) return printf_string("truncated: %zu bytes, a %s needs at least %lld", size, type, (long long)(8 + fixed));
    const int64_t got = read_be(p, 8);
    if (got != hash)
        return printf_string("bad fingerprint 0x%016llx (a %s has 0x%016llx): wrong message type on this channel",
                   (unsigned long long)got, type, (unsigned long long)hash);
    if (static_cast<int64_t>(size) < 8 + fixed)
        return printf_string("truncated: %zu bytes, a %s needs at least %lld", size, type, (long long)(8 + fixed));
    int64_t expected = 8 + fixed;
    std::string fields;
    for (const LengthField &f : lengths) {
        const int64_t n = read_be(p + 8 + f.offset, 4);
        if (n < 0) return printf_string("bad length field %s = %lld in a %s", f.name, (long long)n, type);
        expected += n * f.unit_bytes;
        fields += printf_string("%s%s=%lld", fields.empty() ? "" : ", ", f.name, (long long)n);
    }
    if (static_cast<int64_t>(size) < expected)
        return printf_string("truncated: %zu bytes, the %s declares %lld (%s)", size, type, (long long)expected, fields.c_str());
    if (static_cast<int64_t>(size) > expected)
        return printf_string("wrong size: %zu bytes, the %s declares %lld (%s)", size, type, (long long)expected, fields.c_str());
    return "";
}

// Wire layouts (bytes after the 8-byte fingerprint; see the .lcm files).
// stereo_t: utime 8, sequence 4, frame_number 8, width 4, height 4, row_stride 4, pixel_format 1,
// size 4 = 37.
constexpr int kStereoFixed = 37;
// lidar_t: utime 8, frame 1, lidar_to_camera 128, num_points 4 = 141.
constexpr int kLidarFixed = 141;
// calibration_t: utime 8, width 4, height 4, 5 doubles = 56.
constexpr int kCalibrationFixed = 56;
// status_t: utime 8, uptime 8, 19 int64 counters 152, queue_depth 4, queue_capacity 4, busy 1,
// shard_index 4, shard_count 4, shards_dead 4, pairs_lost_dead_shard 8, instance_id and 4 int64
// counters 40, 5 floats 20, length of last_error 4 = 261.
constexpr int kStatusFixed = 261;
// scene_flow_t: utime 8, utime0 8, sequence 4, lidar_flags 1, lidar_utime0 8, lidar_utime1 8,
// last_stage 1, image_width 4, image_height 4, step 1, width 4, height 4, encoding 1, scale 4,
// compute_seconds 4, plane_size 4, valid_size 4 = 72.
constexpr int kFlowFixed = 72;
// ego_motion_t: utime 8, utime0 8, sequence 4, state 1, transform 128, inliers 4, candidates 4 = 157.
constexpr int kEgoMotionFixed = 157;


// The wire's byte order is the host's: a row of values is one copy.
constexpr bool kLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

void put_le16(uint8_t *p, int16_t v) {
    const auto u = static_cast<uint16_t>(v);
    p[0] = static_cast<uint8_t>(u);
    p[1] = static_cast<uint8_t>(u >> 8);
}

void put_le32f(uint8_t *p, float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(u >> (8 * i));
}

float get_le32f(const uint8_t *p) {
    uint32_t u = 0;
    for (int i = 0; i < 4; ++i) u |= static_cast<uint32_t>(p[i]) << (8 * i);
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

int16_t get_le16(const uint8_t *p) { return static_cast<int16_t>(static_cast<uint16_t>(p[0] | (p[1] << 8))); }

// Each value / kInt16Scale to the nearest integer (ties to even), within +-32767; not finite: 0.
// The scale is a power of two, so the product is exact in float, and adding and taking away
// 1.5 * 2^23 rounds |s| < 2^22 as nearbyint does, without a libm call per value. Every step
// runs on every value and the non-finite ones' 0 is chosen at the end (a bit test), so that the
// loop vectorises (with -fno-trapping-math, bridge/CMakeLists.txt). It needs IEEE
// single-precision arithmetic (no -ffast-math); test_flow_int16_rule checks the rule.
void to_fixed_row(const float *values, int16_t *out, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        const float value = values[i];
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD == 0
        uint32_t bits;
        std::memcpy(&bits, &value, 4);
        float s = value * (1.0f / kInt16Scale);
        s = s > 32767.0f ? 32767.0f : s;
        s = s < -32767.0f ? -32767.0f : s;
        const float rounded = (s + 12582912.0f) - 12582912.0f;
        const float kept = (bits & 0x7f800000u) != 0x7f800000u ? rounded : 0.0f;
        out[i] = static_cast<int16_t>(static_cast<int32_t>(kept));
#else  // wider intermediates (x87) would round the sum elsewhere: the library's rounding
        const double q = std::isfinite(value) ? std::nearbyint(static_cast<double>(value) / kInt16Scale) : 0.0;
        out[i] = static_cast<int16_t>(q > 32767 ? 32767 : q < -32767 ? -32767 : q);
#endif
    }
}

}  // namespace

std::string printf_string(const char *format, ...) {
    char buf[512];
    va_list ap;
    va_start(ap, format);
    std::vsnprintf(buf, sizeof buf, format, ap);
    va_end(ap);
    return buf;
}

StereoMessage::~StereoMessage() {
    if (decoded_) lidarflow_stereo_t_decode_cleanup(&msg_);
}

void StereoMessage::assign_packed(const lidarflow_stereo_t &header, std::vector<uint8_t> pixels) {
    owned_ = std::move(pixels);
    msg_ = header;
    msg_.left = owned_.data();
    msg_.right = owned_.data() + owned_.size() / 2;
    has_frame_number_ = false;
}

lf_image_t StereoMessage::left() const {
    lf_image_t im{msg_.left, static_cast<uint32_t>(msg_.width), static_cast<uint32_t>(msg_.height),
                  static_cast<uint64_t>(msg_.row_stride), msg_.pixel_format};
    return im;
}

lf_image_t StereoMessage::right() const {
    lf_image_t im = left();
    im.data = msg_.right;
    return im;
}

std::string decode_stereo(const void *data, size_t size, StereoMessage &out) {
    std::string err = check_wire(data, size, "lidarflow.stereo_t", __lidarflow_stereo_t_get_hash(), kStereoFixed,
                                 {{"size", 33, 2}});
    if (!err.empty()) return err;
    // The dimensions are checked on the wire, before decoding: lcm-gen's decoder copies a
    // zero-sized array with memcpy from a NULL allocation (undefined behaviour), and valid
    // dimensions rule that out (size >= 1).
    const auto *p = static_cast<const uint8_t *>(data) + 8;
    const int64_t width = read_be(p + 20, 4), height = read_be(p + 24, 4), row_stride = read_be(p + 28, 4);
    const auto pixel_format = static_cast<int8_t>(p[32]);
    const int64_t image_size = read_be(p + 33, 4);
    const int bpp = bytes_per_pixel(pixel_format);
    if (bpp == 0) return printf_string("unknown pixel_format %d (1 gray8, 2 rgb8, 3 bgr8)", pixel_format);
    if (width < 1 || height < 1 || width > 16384 || height > 16384)
        return printf_string("inconsistent dimensions: %lldx%lld (each side 1..16384)", (long long)width, (long long)height);
    if (row_stride < width * bpp)
        return printf_string("inconsistent dimensions: row_stride %lld < width %lld x %d bytes", (long long)row_stride,
                   (long long)width, bpp);
    if (image_size != row_stride * height)
        return printf_string("inconsistent dimensions: size %lld != row_stride %lld x height %lld", (long long)image_size,
                   (long long)row_stride, (long long)height);
    lidarflow_stereo_t m;
    std::memset(&m, 0, sizeof m);
    if (lidarflow_stereo_t_decode(data, 0, static_cast<int>(size), &m) != static_cast<int>(size)) {
        lidarflow_stereo_t_decode_cleanup(&m);
        return "decoding failed";
    }
    out.msg_ = m;
    out.decoded_ = true;
    return "";
}

lf_lidar_t LidarSweep::view() const {
    lf_lidar_t l{kind, static_cast<uint32_t>(xyz.size() / 3), xyz.empty() ? nullptr : xyz.data(), 12};
    return l;
}

lf_lidar_t LidarSweep::lidar_frame_view() const {
    lf_lidar_t l{LF_LIDAR_POINTS_LIDAR, static_cast<uint32_t>(lidar_xyz.size() / 3),
                 lidar_xyz.empty() ? nullptr : lidar_xyz.data(), 12};
    return l;
}

std::string decode_lidar(const void *data, size_t size, LidarSweep &out) {
    std::string err = check_wire(data, size, "lidarflow.lidar_t", __lidarflow_lidar_t_get_hash(), kLidarFixed,
                                 {{"num_points", 137, 12}});
    if (!err.empty()) return err;
    lidarflow_lidar_t m;
    std::memset(&m, 0, sizeof m);
    if (lidarflow_lidar_t_decode(data, 0, static_cast<int>(size), &m) != static_cast<int>(size)) {
        lidarflow_lidar_t_decode_cleanup(&m);
        return "decoding failed";
    }
    const double *T = m.lidar_to_camera;
    if (m.frame != LIDARFLOW_LIDAR_T_FRAME_CAMERA && m.frame != LIDARFLOW_LIDAR_T_FRAME_LIDAR &&
        m.frame != LIDARFLOW_LIDAR_T_FRAME_DISPARITY) {
        err = printf_string("unknown frame %d (1 camera, 2 lidar, 3 disparity)", m.frame);
    } else if (m.frame == LIDARFLOW_LIDAR_T_FRAME_LIDAR) {
        for (int i = 0; i < 16 && err.empty(); ++i)
            if (!std::isfinite(T[i])) err = printf_string("lidar_to_camera[%d] is not finite", i);
        if (err.empty() && (T[12] != 0 || T[13] != 0 || T[14] != 0 || T[15] != 1))
            err = printf_string("lidar_to_camera's last row is %g %g %g %g, not 0 0 0 1", T[12], T[13], T[14], T[15]);
    }
    for (int32_t i = 0; i < m.num_points && err.empty(); ++i)
        if (!std::isfinite(m.x[i]) || !std::isfinite(m.y[i]) || !std::isfinite(m.z[i]))
            err = printf_string("point %d is not finite", i);
    std::vector<float> xyz, lidar_xyz;
    if (err.empty()) xyz.resize(3 * static_cast<size_t>(m.num_points));
    if (err.empty() && m.frame == LIDARFLOW_LIDAR_T_FRAME_LIDAR) lidar_xyz.resize(xyz.size());
    for (int32_t i = 0; i < m.num_points && err.empty(); ++i) {
        float *o = &xyz[3 * static_cast<size_t>(i)];
        if (m.frame == LIDARFLOW_LIDAR_T_FRAME_LIDAR) {
            float *raw = &lidar_xyz[3 * static_cast<size_t>(i)];
            raw[0] = m.x[i];
            raw[1] = m.y[i];
            raw[2] = m.z[i];
            // In double: the bridge's transform must not add more rounding than one float cast.
            const double x = m.x[i], y = m.y[i], z = m.z[i];
            for (int r = 0; r < 3; ++r) {
                const double c = T[4 * r] * x + T[4 * r + 1] * y + T[4 * r + 2] * z + T[4 * r + 3];
                // Finite inputs can still leave float's range (or give inf - inf = NaN).
                if (!(std::fabs(c) <= std::numeric_limits<float>::max()))
                    err = printf_string("point %d is out of float range after lidar_to_camera", i);
                o[r] = static_cast<float>(c);
            }
        } else {
            o[0] = m.x[i];
            o[1] = m.y[i];
            o[2] = m.z[i];
        }
    }
    if (err.empty()) {
        out.utime = m.utime;
        out.kind = m.frame == LIDARFLOW_LIDAR_T_FRAME_DISPARITY ? LF_LIDAR_DISPARITY : LF_LIDAR_POINTS_CAMERA;
        out.xyz = std::move(xyz);
        out.in_lidar_frame = m.frame == LIDARFLOW_LIDAR_T_FRAME_LIDAR;
        out.lidar_xyz = std::move(lidar_xyz);
        std::copy(T, T + 16, out.lidar_to_camera);
    }
    lidarflow_lidar_t_decode_cleanup(&m);
    return err;
}

std::string decode_calibration(const void *data, size_t size, lf_calibration_t *out, int32_t *width,
                               int32_t *height) {
    std::string err =
        check_wire(data, size, "lidarflow.calibration_t", __lidarflow_calibration_t_get_hash(), kCalibrationFixed, {});
    if (!err.empty()) return err;
    lidarflow_calibration_t m;
    std::memset(&m, 0, sizeof m);
    if (lidarflow_calibration_t_decode(data, 0, static_cast<int>(size), &m) != static_cast<int>(size))
        return "decoding failed";
    const double v[5] = {m.fx, m.fy, m.cx, m.cy, m.baseline};
    for (double x : v)
        if (!std::isfinite(x)) return "calibration has a non-finite value";
    if (!(m.fx > 0 && m.fy > 0 && m.baseline > 0))
        return printf_string("calibration needs fx, fy, baseline > 0 (got %g, %g, %g)", m.fx, m.fy, m.baseline);
    if (m.width < 0 || m.height < 0 || m.width > 16384 || m.height > 16384)
        return printf_string("calibration image size %dx%d out of range", m.width, m.height);
    lf_calibration_init(out);
    out->fx = m.fx;
    out->fy = m.fy;
    out->cx = m.cx;
    out->cy = m.cy;
    out->baseline = m.baseline;
    *width = m.width;
    *height = m.height;
    return "";
}

lidarflow_calibration_t calibration_message(const lf_calibration_t &cal, int64_t utime, int32_t width,
                                            int32_t height) {
    lidarflow_calibration_t m;
    std::memset(&m, 0, sizeof m);
    m.utime = utime;
    m.width = width;
    m.height = height;
    m.fx = cal.fx;
    m.fy = cal.fy;
    m.cx = cal.cx;
    m.cy = cal.cy;
    m.baseline = cal.baseline;
    return m;
}

bool parse_flow_encoding(const std::string &name, FlowEncoding *out) {
    if (name == "float32") *out = FlowEncoding::Float32;
    else if (name == "int16") *out = FlowEncoding::Int16;
    else return false;
    return true;
}

lidarflow_scene_flow_t FlowMessage::message() {
    lidarflow_scene_flow_t m = header;
    m.u = u.data();
    m.v = v.data();
    m.d0 = d0.data();
    m.d1 = d1.data();
    m.valid = valid.data();
    return m;
}

bool encode_flow(const lf_result_views_t &views, FlowEncoding encoding, int step, FlowMessage &out,
                 std::string *error) {
    if (step < 1 || step > 16) {
        *error = printf_string("step %d out of range 1..16", step);
        return false;
    }
    if (!views.u.data || !views.v.data || !views.d0.data || !views.d1.data || !views.valid.data) {
        *error = "result views without data";
        return false;
    }
    const uint32_t w = (views.width + step - 1) / step, h = (views.height + step - 1) / step;
    const int value_bytes = encoding == FlowEncoding::Float32 ? 4 : 2;
    const size_t n = static_cast<size_t>(w) * h;
    const lf_view_t *src[4] = {&views.u, &views.v, &views.d0, &views.d1};
    std::vector<uint8_t> *dst[4] = {&out.u, &out.v, &out.d0, &out.d1};
    for (int k = 0; k < 4; ++k) dst[k]->assign(n * value_bytes, 0);
    out.valid.assign(n, 0);
    // A row's values gathered (views have any alignment), then converted in plain loops that
    // vectorise: a message is on its way to the bus after every pair.
    std::vector<float> values(w);
    std::vector<int16_t> fixed(w);
    for (uint32_t y = 0; y < h; ++y) {
        const uint32_t sy = y * static_cast<uint32_t>(step);
        for (int k = 0; k < 4; ++k) {
            const auto *row = reinterpret_cast<const uint8_t *>(src[k]->data) + sy * src[k]->stride_bytes;
            uint8_t *o = dst[k]->data() + static_cast<size_t>(y) * w * value_bytes;
            if (step == 1)
                std::memcpy(values.data(), row, 4 * static_cast<size_t>(w));
            else
                for (uint32_t x = 0; x < w; ++x) std::memcpy(&values[x], row + 4 * static_cast<size_t>(x) * step, 4);
            if (encoding == FlowEncoding::Float32) {
                if (kLittleEndian) std::memcpy(o, values.data(), 4 * static_cast<size_t>(w));
                else for (uint32_t x = 0; x < w; ++x) put_le32f(o + 4 * x, values[x]);
            } else {
                to_fixed_row(values.data(), fixed.data(), w);
                if (kLittleEndian) std::memcpy(o, fixed.data(), 2 * static_cast<size_t>(w));
                else for (uint32_t x = 0; x < w; ++x) put_le16(o + 2 * x, fixed[x]);
            }
        }
        const auto *vrow = static_cast<const uint8_t *>(views.valid.data) + sy * views.valid.stride_bytes;
        uint8_t *valid = out.valid.data() + static_cast<size_t>(y) * w;
        if (step == 1)
            for (uint32_t x = 0; x < w; ++x) valid[x] = vrow[x] != 0;
        else
            for (uint32_t x = 0; x < w; ++x) valid[x] = vrow[x * step] != 0;
    }
    out.header.image_width = static_cast<int32_t>(views.width);
    out.header.image_height = static_cast<int32_t>(views.height);
    out.header.step = static_cast<int8_t>(step);
    out.header.width = static_cast<int32_t>(w);
    out.header.height = static_cast<int32_t>(h);
    out.header.encoding = static_cast<int8_t>(encoding);
    out.header.scale = encoding == FlowEncoding::Float32 ? 1.0f : kInt16Scale;
    out.header.plane_size = static_cast<int32_t>(n * value_bytes);
    out.header.valid_size = static_cast<int32_t>(n);
    return true;
}

std::vector<uint8_t> encode_scene_flow(lidarflow_scene_flow_t &msg) {
    return encode_message(msg, lidarflow_scene_flow_t_encoded_size, lidarflow_scene_flow_t_encode);
}

bool scene_flow_utime(const void *data, size_t size, int64_t *utime) {
    const auto *p = static_cast<const uint8_t *>(data);
    if (size < 8 + 8 || read_be(p, 8) != __lidarflow_scene_flow_t_get_hash()) return false;
    *utime = read_be(p + 8, 8);
    return true;
}

std::string decode_scene_flow(const void *data, size_t size, DecodedFlow &out) {
    std::string err = check_wire(data, size, "lidarflow.scene_flow_t", __lidarflow_scene_flow_t_get_hash(),
                                 kFlowFixed, {{"plane_size", 64, 4}, {"valid_size", 68, 1}});
    if (!err.empty()) return err;
    // Sizes are checked on the wire before decoding, as for stereo_t: sides in 1..16384 keep
    // width x height x 4 far from overflow, and no plane is empty.
    const auto *p = static_cast<const uint8_t *>(data) + 8;
    const int64_t image_width = read_be(p + 38, 4), image_height = read_be(p + 42, 4);
    const int64_t step = static_cast<int8_t>(p[46]);
    const int64_t width = read_be(p + 47, 4), height = read_be(p + 51, 4);
    const auto encoding = static_cast<int8_t>(p[55]);
    const int64_t plane_size = read_be(p + 64, 4), valid_size = read_be(p + 68, 4);
    const int value_bytes = encoding == LIDARFLOW_SCENE_FLOW_T_ENCODING_FLOAT32 ? 4
                            : encoding == LIDARFLOW_SCENE_FLOW_T_ENCODING_INT16 ? 2
                                                                                : 0;
    if (value_bytes == 0) return printf_string("unknown encoding %d (1 float32, 2 int16)", encoding);
    if (image_width < 1 || image_height < 1 || image_width > 16384 || image_height > 16384 || step < 1 || step > 16)
        return printf_string("inconsistent dimensions: image %lldx%lld (each side 1..16384), step %lld (1..16)",
                   (long long)image_width, (long long)image_height, (long long)step);
    if (width != (image_width + step - 1) / step || height != (image_height + step - 1) / step)
        return printf_string("inconsistent dimensions: planes %lldx%lld, image %lldx%lld subsampled by %lld", (long long)width,
                   (long long)height, (long long)image_width, (long long)image_height, (long long)step);
    const int64_t n = width * height;
    if (plane_size != n * value_bytes || valid_size != n)
        return printf_string("inconsistent dimensions: %lldx%lld with plane_size %lld, valid_size %lld", (long long)width,
                   (long long)height, (long long)plane_size, (long long)valid_size);
    lidarflow_scene_flow_t m;
    std::memset(&m, 0, sizeof m);
    if (lidarflow_scene_flow_t_decode(data, 0, static_cast<int>(size), &m) != static_cast<int>(size)) {
        lidarflow_scene_flow_t_decode_cleanup(&m);
        return "decoding failed";
    }
    if (encoding == LIDARFLOW_SCENE_FLOW_T_ENCODING_INT16 && !(std::isfinite(m.scale) && m.scale > 0))
        err = printf_string("int16 encoding with scale %g (finite, > 0)", m.scale);
    for (int64_t i = 0; i < n && err.empty(); ++i)
        if (m.valid[i] > 1) err = printf_string("valid[%lld] = %d, not 0 or 1", (long long)i, m.valid[i]);
    if (err.empty()) {
        const uint8_t *src[4] = {m.u, m.v, m.d0, m.d1};
        std::vector<float> *dst[4] = {&out.u, &out.v, &out.d0, &out.d1};
        for (int k = 0; k < 4; ++k) {
            dst[k]->resize(static_cast<size_t>(n));
            for (int64_t i = 0; i < n; ++i)
                (*dst[k])[i] = value_bytes == 4 ? get_le32f(src[k] + 4 * i)
                                                : static_cast<float>(get_le16(src[k] + 2 * i)) * m.scale;
        }
        out.valid.assign(m.valid, m.valid + n);
    }
    lidarflow_scene_flow_t_decode_cleanup(&m);
    out.header = m;
    out.header.u = out.header.v = out.header.d0 = out.header.d1 = out.header.valid = nullptr;
    return err;
}

std::string decode_status(const void *data, size_t size, StatusMessage &out) {
    const std::string err = check_wire(data, size, "lidarflow.status_t", __lidarflow_status_t_get_hash(), kStatusFixed,
                                       {{"last_error length", kStatusFixed - 4, 1}});
    if (!err.empty()) return err;
    // The string's length counts its terminating NUL: lcm-gen's decoder neither checks that
    // nor that the length is positive.
    const auto *p = static_cast<const uint8_t *>(data);
    if (size == 8 + kStatusFixed || p[size - 1] != 0) return "last_error is not a NUL-terminated string";
    lidarflow_status_t m;
    std::memset(&m, 0, sizeof m);
    if (lidarflow_status_t_decode(data, 0, static_cast<int>(size), &m) != static_cast<int>(size)) {
        lidarflow_status_t_decode_cleanup(&m);
        return "decoding failed";
    }
    out.last_error = m.last_error;
    out.fields = m;
    out.fields.last_error = nullptr;
    lidarflow_status_t_decode_cleanup(&m);
    return "";
}

int64_t message_fingerprint(const void *data, size_t size) {
    return size < 8 ? 0 : read_be(static_cast<const uint8_t *>(data), 8);
}

std::string check_lidar_to_camera(const double *T) {
    for (int i = 0; i < 16; ++i)
        if (!std::isfinite(T[i])) return printf_string("lidar_to_camera[%d] is not finite", i);
    if (T[12] != 0 || T[13] != 0 || T[14] != 0 || T[15] != 1)
        return printf_string("lidar_to_camera's last row is %g %g %g %g, not 0 0 0 1", T[12], T[13], T[14], T[15]);
    return "";
}

lidarflow_ego_motion_t ego_motion_message(const lf_ego_motion_t &ego, int64_t utime, int64_t utime0, int32_t sequence) {
    lidarflow_ego_motion_t m;
    std::memset(&m, 0, sizeof m);
    m.utime = utime;
    m.utime0 = utime0;
    m.sequence = sequence;
    m.state = static_cast<int8_t>(ego.state);
    for (int k = 0; k < 16; ++k) m.transform[k] = ego.transform[k];
    // The counts are matches of one frame: far below 2^31.
    m.inliers = static_cast<int32_t>(std::min<uint32_t>(ego.inliers, std::numeric_limits<int32_t>::max()));
    m.candidates = static_cast<int32_t>(std::min<uint32_t>(ego.candidates, std::numeric_limits<int32_t>::max()));
    return m;
}

std::vector<uint8_t> encode_ego_motion(lidarflow_ego_motion_t &msg) {
    return encode_message(msg, lidarflow_ego_motion_t_encoded_size, lidarflow_ego_motion_t_encode);
}

std::vector<uint8_t> encode_quality(int64_t utime, int64_t utime0, int32_t sequence, uint32_t flags, const char *reason) {
    lidarflow_quality_t m;
    std::memset(&m, 0, sizeof m);
    m.utime = utime;
    m.utime0 = utime0;
    m.sequence = sequence;
    m.flags = static_cast<int32_t>(flags);
    m.reason = const_cast<char *>(reason);  // lcm-gen's struct is not const-correct; only read
    return encode_message(m, lidarflow_quality_t_encoded_size, lidarflow_quality_t_encode);
}

std::string decode_ego_motion(const void *data, size_t size, lidarflow_ego_motion_t &out) {
    const std::string err = check_wire(data, size, "lidarflow.ego_motion_t", __lidarflow_ego_motion_t_get_hash(),
                                       kEgoMotionFixed, {});
    if (!err.empty()) return err;
    lidarflow_ego_motion_t m;
    std::memset(&m, 0, sizeof m);
    if (lidarflow_ego_motion_t_decode(data, 0, static_cast<int>(size), &m) != static_cast<int>(size))
        return "decoding failed";
    if (m.state < LIDARFLOW_EGO_MOTION_T_STATE_OK || m.state > LIDARFLOW_EGO_MOTION_T_STATE_DISABLED)
        return printf_string("unknown state %d (0 ok .. 4 disabled)", m.state);
    const double *T = m.transform;
    for (int k = 0; k < 16; ++k)
        if (!std::isfinite(T[k])) return printf_string("transform[%d] is not finite", k);
    if (T[12] != 0 || T[13] != 0 || T[14] != 0 || T[15] != 1)
        return printf_string("transform's last row is %g %g %g %g, not 0 0 0 1", T[12], T[13], T[14], T[15]);
    if (m.state == LIDARFLOW_EGO_MOTION_T_STATE_OK) {
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                double dot = 0;
                for (int k = 0; k < 3; ++k) dot += T[4 * k + i] * T[4 * k + j];
                if (!(std::fabs(dot - (i == j ? 1.0 : 0.0)) <= 1e-6))
                    return printf_string("transform's rotation is not orthonormal ((R^T R)[%d][%d] = %.9g)", i, j, dot);
            }
        const double det = T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8]) +
                           T[2] * (T[4] * T[9] - T[5] * T[8]);
        if (!(det > 0)) return printf_string("transform's rotation has determinant %g (a reflection)", det);
    } else {
        for (int k = 0; k < 16; ++k)
            if (T[k] != (k % 5 == 0 ? 1.0 : 0.0))
                return printf_string("state %d (no ego-motion) with a transform other than the identity", m.state);
    }
    if (m.inliers < 0 || m.candidates < 0 || m.inliers > m.candidates)
        return printf_string("inliers %d, candidates %d (0 <= inliers <= candidates)", m.inliers, m.candidates);
    out = m;
    return "";
}

}  // namespace lidarflow::bridge
