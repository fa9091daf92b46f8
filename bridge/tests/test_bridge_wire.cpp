// SPDX-License-Identifier: MIT
// The bridge's message decoders (wire.cpp) on messages that lcm-gen's decoders mishandle:
// zero-sized arrays (a memcpy from NULL), sizes whose products overflow, strings without a
// terminating NUL, messages beyond what an int counts. Messages are written byte by byte here,
// since lcm-gen's encoder cannot produce most of them (it has the same memcpy on empty arrays).
// Found by, and kept in step with, the fuzz targets of tests/fuzz/ (fuzz_lcm_*).
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "wire.hpp"

// cmocka 1.1 has no extern "C" guard of its own; included last because of its macros.
extern "C" {
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
}

using namespace lidarflow::bridge;

namespace {

// Big-endian LCM wire writer.
struct Wire {
    std::vector<uint8_t> b;
    Wire &be(uint64_t v, int bytes) {
        for (int i = bytes - 1; i >= 0; --i) b.push_back(static_cast<uint8_t>(v >> (8 * i)));
        return *this;
    }
    Wire &i8(int v) { return be(static_cast<uint8_t>(v), 1); }
    Wire &i32(int64_t v) { return be(static_cast<uint32_t>(v), 4); }
    Wire &i64(int64_t v) { return be(static_cast<uint64_t>(v), 8); }
    Wire &f32(float f) {
        uint32_t u;
        std::memcpy(&u, &f, 4);
        return be(u, 4);
    }
    Wire &f64(double d) {
        uint64_t u;
        std::memcpy(&u, &d, 8);
        return be(u, 8);
    }
    Wire &bytes(size_t n, uint8_t value = 0) {
        b.insert(b.end(), n, value);
        return *this;
    }
};

std::vector<uint8_t> stereo(int32_t width, int32_t height, int32_t stride, int8_t format, int32_t size) {
    Wire w;
    w.i64(__lidarflow_stereo_t_get_hash()).i64(7).i32(0).i64(0).i32(width).i32(height).i32(stride).i8(format).i32(size);
    return w.bytes(2 * static_cast<size_t>(size < 0 ? 0 : size), 9).b;
}

struct FlowFields {
    int32_t image_width = 5, image_height = 3;
    int8_t step = 2;
    int32_t width = 3, height = 2;
    int8_t encoding = LIDARFLOW_SCENE_FLOW_T_ENCODING_INT16;
    float scale = 1.0f / 32;
    int32_t plane_size = 12, valid_size = 6;
    uint8_t valid_byte = 1;
};

std::vector<uint8_t> flow(const FlowFields &f) {
    Wire w;
    w.i64(__lidarflow_scene_flow_t_get_hash()).i64(2).i64(1).i32(0).i8(0).i64(0).i64(0).i8(4);
    w.i32(f.image_width).i32(f.image_height).i8(f.step).i32(f.width).i32(f.height).i8(f.encoding);
    w.f32(f.scale).f32(0.5f).i32(f.plane_size).i32(f.valid_size);
    for (int k = 0; k < 4; ++k)
        for (int32_t i = 0; i < f.plane_size; ++i) w.i8(i % 2 == 0 ? 32 * (k + 1) : 0);  // int16: k + 1 px
    return w.bytes(static_cast<size_t>(f.valid_size), f.valid_byte).b;
}

std::vector<uint8_t> status(int32_t string_length, const std::string &text) {
    Wire w;
    w.i64(__lidarflow_status_t_get_hash()).i64(11).f64(2.5);
    for (int i = 0; i < 19; ++i) w.i64(100 + i);
    w.i32(3).i32(4).i8(1).i32(2).i32(3).i32(1).i64(7);
    w.i64(-5).i64(21).i64(22).i64(23).i64(24);  // instance_id, the shard watch's and calibration counters
    for (int i = 0; i < 5; ++i) w.f32(1.5f * i);
    w.i32(string_length);
    w.b.insert(w.b.end(), text.begin(), text.end());
    return w.b;
}

void assert_error(const std::string &err, const char *needle) {
    if (err.find(needle) == std::string::npos) fail_msg("expected an error with \"%s\", got \"%s\"", needle, err.c_str());
}

// A stereo_t with zero-sized images: rejected on its dimensions, before lcm-gen's decoder (which
// would memcpy 0 bytes from a NULL allocation: undefined behaviour, caught by UBSan) runs.
void test_stereo_zero_size(void **) {
    StereoMessage m;
    std::vector<uint8_t> b = stereo(0, 0, 0, LIDARFLOW_STEREO_T_PIXEL_GRAY8, 0);
    assert_error(decode_stereo(b.data(), b.size(), m), "inconsistent dimensions: 0x0");
    StereoMessage m2;
    b = stereo(4, 3, 0, LIDARFLOW_STEREO_T_PIXEL_GRAY8, 0);
    assert_error(decode_stereo(b.data(), b.size(), m2), "row_stride 0 < width 4");
    StereoMessage m3;
    b = stereo(4, 3, 4, 0, 0);
    assert_error(decode_stereo(b.data(), b.size(), m3), "unknown pixel_format 0");
    // Consistent arrays, inconsistent size field.
    StereoMessage m4;
    b = stereo(4, 3, 4, LIDARFLOW_STEREO_T_PIXEL_GRAY8, 13);
    assert_error(decode_stereo(b.data(), b.size(), m4), "size 13 != row_stride 4 x height 3");
    // The smallest valid message decodes, with both images intact.
    StereoMessage ok;
    b = stereo(1, 1, 1, LIDARFLOW_STEREO_T_PIXEL_GRAY8, 1);
    assert_string_equal(decode_stereo(b.data(), b.size(), ok).c_str(), "");
    assert_int_equal(ok.left().width, 1);
    assert_int_equal(static_cast<const uint8_t *>(ok.right().data)[0], 9);
}

// Sizes beyond what lcm-gen's int-counting decoders take are refused before anything is read
// past the fingerprint.
void test_oversized_message(void **) {
    std::vector<uint8_t> b = stereo(1, 1, 1, LIDARFLOW_STEREO_T_PIXEL_GRAY8, 1);
    StereoMessage m;
    assert_error(decode_stereo(b.data(), static_cast<size_t>(INT_MAX) + 1, m), "oversized");
    DecodedFlow f;
    assert_error(decode_scene_flow(b.data(), static_cast<size_t>(INT_MAX) + 9, f), "oversized");
}

// scene_flow_t sides of 2^31 - 1 made width x height x 4 overflow int64 (undefined
// behaviour); sides are now bounded before any product is formed.
void test_flow_size_overflow(void **) {
    FlowFields f;
    f.width = f.height = INT32_MAX;
    f.plane_size = f.valid_size = 0;
    std::vector<uint8_t> b = flow(f);
    DecodedFlow out;
    assert_error(decode_scene_flow(b.data(), b.size(), out), "inconsistent dimensions");
    f.image_width = f.image_height = INT32_MAX;
    b = flow(f);
    assert_error(decode_scene_flow(b.data(), b.size(), out), "image 2147483647x2147483647");
}

// Empty planes (width 0) would reach lcm-gen's memcpy from NULL; a plane size that does not fit
// the sides, step 0, bytes of valid other than 0/1, and a NaN int16 scale are all refused.
void test_flow_consistency(void **) {
    DecodedFlow out;
    FlowFields f;
    std::vector<uint8_t> b = flow(f);
    assert_string_equal(decode_scene_flow(b.data(), b.size(), out).c_str(), "");
    assert_int_equal(out.u.size(), 6);
    for (size_t i = 0; i < 6; ++i) {
        assert_true(out.u[i] == 1.0f && out.v[i] == 2.0f && out.d0[i] == 3.0f && out.d1[i] == 4.0f);
        assert_int_equal(out.valid[i], 1);
    }
    assert_int_equal(out.header.image_width, 5);
    assert_null(out.header.u);

    FlowFields e = f;
    e.width = e.height = e.plane_size = e.valid_size = 0;
    b = flow(e);
    assert_error(decode_scene_flow(b.data(), b.size(), out), "planes 0x0, image 5x3 subsampled by 2");
    e = f;
    e.step = 0;
    b = flow(e);
    assert_error(decode_scene_flow(b.data(), b.size(), out), "step 0");
    e = f;
    e.plane_size = 24;  // float32-sized planes with int16 encoding
    b = flow(e);
    assert_error(decode_scene_flow(b.data(), b.size(), out), "plane_size 24");
    e = f;
    e.valid_byte = 2;
    b = flow(e);
    assert_error(decode_scene_flow(b.data(), b.size(), out), "not 0 or 1");
    e = f;
    e.scale = NAN;
    b = flow(e);
    assert_error(decode_scene_flow(b.data(), b.size(), out), "scale");
    e = f;
    e.encoding = 3;
    b = flow(e);
    assert_error(decode_scene_flow(b.data(), b.size(), out), "unknown encoding 3");
}

// A FRAME_LIDAR sweep whose finite points leave float's range once moved by a finite
// transform was passed on with inf entries; it is refused, naming the point.
void test_lidar_transform_range(void **) {
    auto sweep = [](double scale, float x) {
        Wire w;
        w.i64(__lidarflow_lidar_t_get_hash()).i64(3).i8(LIDARFLOW_LIDAR_T_FRAME_LIDAR);
        for (int i = 0; i < 16; ++i) w.f64(i == 0 ? scale : i % 5 == 0 ? 1.0 : 0.0);
        w.i32(2).f32(1.0f).f32(x).f32(2.0f).f32(3.0f).f32(4.0f).f32(5.0f);
        return w.b;
    };
    LidarSweep s;
    std::vector<uint8_t> b = sweep(2.0, 1e30f);
    assert_string_equal(decode_lidar(b.data(), b.size(), s).c_str(), "");
    assert_int_equal(s.xyz.size(), 6);
    assert_true(s.xyz[0] == 2.0f && s.xyz[3] == 2e30f && s.xyz[5] == 5.0f);
    LidarSweep bad;
    b = sweep(1e10, 1e30f);
    assert_error(decode_lidar(b.data(), b.size(), bad), "point 1 is out of float range");
    assert_true(bad.xyz.empty());
    b = sweep(1e300, 1.0f);  // far beyond float from the first point on
    assert_error(decode_lidar(b.data(), b.size(), bad), "point 0 is out of float range");
}

// status_t's string: length counts the NUL; a zero or negative length, or no NUL at the end, is
// refused (lcm-gen's decoder would hand out an unterminated string or memcpy a negative size).
void test_status_string(void **) {
    StatusMessage s;
    std::vector<uint8_t> b = status(4, std::string("abc\0", 4));
    assert_string_equal(decode_status(b.data(), b.size(), s).c_str(), "");
    assert_string_equal(s.last_error.c_str(), "abc");
    assert_int_equal(s.fields.utime, 11);
    assert_int_equal(s.fields.stereo_received, 100);
    assert_int_equal(s.fields.stereo_lost_in_transport, 101);
    assert_int_equal(s.fields.dropped_shutdown, 111);
    assert_int_equal(s.fields.dropped_unpaired, 112);
    assert_int_equal(s.fields.skipped_other_shard, 113);
    assert_int_equal(s.fields.calibration_malformed, 118);
    assert_int_equal(s.fields.queue_capacity, 4);
    assert_int_equal(s.fields.shard_index, 2);
    assert_int_equal(s.fields.shard_count, 3);
    assert_int_equal(s.fields.shards_dead, 1);
    assert_int_equal(s.fields.pairs_lost_dead_shard, 7);
    assert_int_equal(s.fields.instance_id, -5);
    assert_int_equal(s.fields.shard_index_conflicts, 21);
    assert_int_equal(s.fields.shard_results_ignored, 22);
    assert_int_equal(s.fields.shard_messages_refused, 23);
    assert_int_equal(s.fields.pairs_lost_calibration_change, 24);
    assert_true(s.fields.compute_mean_ms == 6.0f);
    assert_null(s.fields.last_error);

    b = status(0, "");
    assert_error(decode_status(b.data(), b.size(), s), "not a NUL-terminated string");
    b = status(3, "abc");
    assert_error(decode_status(b.data(), b.size(), s), "not a NUL-terminated string");
    b = status(-1, "");
    assert_error(decode_status(b.data(), b.size(), s), "bad length field");
    b = status(5, std::string("abc\0", 4));
    assert_error(decode_status(b.data(), b.size(), s), "truncated");

    // What lcm-gen's encoder writes decodes (the hand-counted layout matches the generated one).
    lidarflow_status_t m;
    std::memset(&m, 0, sizeof m);
    m.results_published = 42;
    m.shards_dead = 2;
    m.pairs_lost_dead_shard = 5;
    m.latency_max_ms = 3.25f;
    char text[] = "last words";
    m.last_error = text;
    std::vector<uint8_t> enc(static_cast<size_t>(lidarflow_status_t_encoded_size(&m)));
    assert_int_equal(lidarflow_status_t_encode(enc.data(), 0, static_cast<int>(enc.size()), &m), enc.size());
    StatusMessage d;
    assert_string_equal(decode_status(enc.data(), enc.size(), d).c_str(), "");
    assert_int_equal(d.fields.results_published, 42);
    assert_int_equal(d.fields.shards_dead, 2);
    assert_int_equal(d.fields.pairs_lost_dead_shard, 5);
    assert_true(d.fields.latency_max_ms == 3.25f);
    assert_string_equal(d.last_error.c_str(), "last words");
}

}  // namespace

// The int16 planes: value * 64 to the nearest integer, ties to even, within +-32767; a value
// that is not finite is 0. Stated per value here, not by the encoder's own arithmetic.
void test_flow_int16_rule(void **) {
    const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
    struct Case {
        float value;
        int expected;
    };
    const Case cases[] = {
        {0.0f, 0},         {-0.0f, 0},          {0.5f / 64, 0},     {1.5f / 64, 2},      {2.5f / 64, 2},
        {-0.5f / 64, 0},   {-1.5f / 64, -2},    {-2.5f / 64, -2},   {0.51f / 64, 1},     {-0.49f / 64, 0},
        {1.0f, 64},        {-3.25f, -208},      {511.98f, 32767},   {511.9921875f, 32767}, {511.984375f, 32767},
        {511.9765625f, 32766}, {-511.99f, -32767}, {512.0f, 32767}, {-512.0f, -32767},   {1e30f, 32767},
        {-1e30f, -32767},  {std::numeric_limits<float>::max(), 32767}, {-std::numeric_limits<float>::max(), -32767},
        {std::numeric_limits<float>::denorm_min(), 0}, {inf, 0}, {-inf, 0}, {nan, 0}, {-nan, 0},
        {1234.5678f / 64, 1235}, {-1234.5f / 64, -1234}, {1235.5f / 64, 1236},
    };
    const int n = static_cast<int>(sizeof cases / sizeof cases[0]);
    std::vector<float> values;
    for (const Case &c : cases) values.push_back(c.value);
    const std::vector<uint8_t> valid(values.size(), 1);
    lf_result_views_t views;
    lf_result_views_init(&views);
    views.width = static_cast<uint32_t>(n);
    views.height = 1;
    for (lf_view_t *p : {&views.u, &views.v, &views.d0, &views.d1}) *p = {values.data(), 4u * n};
    views.valid = {valid.data(), static_cast<uint64_t>(n)};
    FlowMessage out;
    std::string err;
    assert_true(encode_flow(views, FlowEncoding::Int16, 1, out, &err));
    for (const std::vector<uint8_t> *plane : {&out.u, &out.v, &out.d0, &out.d1}) {
        assert_int_equal(plane->size(), 2u * n);
        for (int i = 0; i < n; ++i) {
            const int got = static_cast<int16_t>(static_cast<uint16_t>((*plane)[2 * i] | ((*plane)[2 * i + 1] << 8)));
            if (got != cases[i].expected) fail_msg("value %.9g: %d, expected %d", cases[i].value, got, cases[i].expected);
        }
    }
}

// ego_motion_t: what ego_motion_message + encode_ego_motion write decodes to the same fields;
// the decoder refuses what is no rigid motion (the same rules as lidarflow_lcm's decoder).
void test_ego_motion(void **) {
    lf_ego_motion_t e;
    lf_ego_motion_init(&e);
    const double c = std::cos(0.1), s = std::sin(0.1);
    const double T[16] = {c, 0, s, 0.1, 0, 1, 0, 0, -s, 0, c, -0.8, 0, 0, 0, 1};
    std::copy(T, T + 16, e.transform);
    e.inliers = 5;
    e.candidates = 9;
    lidarflow_ego_motion_t m = ego_motion_message(e, 2000, 1000, 7);
    const std::vector<uint8_t> bytes = encode_ego_motion(m);
    assert_int_equal(bytes.size(), 165);
    lidarflow_ego_motion_t got;
    assert_true(decode_ego_motion(bytes.data(), bytes.size(), got).empty());
    assert_true(got.utime == 2000 && got.utime0 == 1000 && got.sequence == 7 && got.state == 0);
    assert_true(got.inliers == 5 && got.candidates == 9);
    assert_memory_equal(got.transform, T, sizeof T);
    assert_error(decode_ego_motion(bytes.data(), bytes.size() - 1, got), "truncated");

    auto refused = [&](lidarflow_ego_motion_t bad, const char *needle) {
        const std::vector<uint8_t> b = encode_ego_motion(bad);
        assert_error(decode_ego_motion(b.data(), b.size(), got), needle);
    };
    lidarflow_ego_motion_t bad = m;
    bad.state = 5;
    refused(bad, "unknown state 5");
    bad = m;
    bad.transform[3] = std::numeric_limits<double>::quiet_NaN();
    refused(bad, "transform[3] is not finite");
    bad = m;
    bad.transform[14] = 0.5;
    refused(bad, "last row");
    bad = m;
    bad.transform[1] = 0.5;
    refused(bad, "not orthonormal");
    bad = m;
    for (int r = 0; r < 3; ++r) bad.transform[4 * r] = -bad.transform[4 * r];
    refused(bad, "determinant");
    bad = m;
    bad.state = LIDARFLOW_EGO_MOTION_T_STATE_TOO_FEW_INLIERS;
    refused(bad, "other than the identity");
    bad = m;
    bad.inliers = 10;
    refused(bad, "inliers 10, candidates 9");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stereo_zero_size),  cmocka_unit_test(test_oversized_message),
        cmocka_unit_test(test_flow_size_overflow), cmocka_unit_test(test_flow_consistency),
        cmocka_unit_test(test_lidar_transform_range), cmocka_unit_test(test_status_string),
        cmocka_unit_test(test_flow_int16_rule), cmocka_unit_test(test_ego_motion),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
