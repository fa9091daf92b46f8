/* SPDX-License-Identifier: MIT */
/* C ABI: the result side — info, timings, copies into caller planes with strides, borrowed
 * views, the 3-D form — and that equivalent inputs (LiDAR kinds, RGB/BGR, thread counts) give
 * bit-identical results. Compiled as C99 against the public header only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "capi_scene.h"

#define W 160
#define H 64

typedef struct fixture_t {
    scene_t scene;
    lf_estimator_t *est;      /* holds the result of the scene's pair */
    scene_result_t result;    /* a copy of it */
} fixture_t;

static lf_estimator_t *new_estimator(const scene_t *s, int threads, const lf_calibration_t *cal) {
    lf_options_t *o = scene_options(threads);
    lf_calibration_t c = cal ? *cal : scene_calibration(s);
    lf_estimator_t *e = NULL;
    if (!o || lf_create(o, &c, &e) != LF_OK) e = NULL;
    lf_options_destroy(o);
    return e;
}

static int group_setup(void **state) {
    static fixture_t f;
    if (!scene_make(&f.scene, W, H, 10, 3, 1, 7)) return -1;
    f.est = new_estimator(&f.scene, 1, NULL);
    if (!f.est || scene_push_pair(f.est, &f.scene, 0, 1) != LF_OK || scene_result_fetch(f.est, &f.result) != LF_OK) {
        fprintf(stderr, "setup failed: %s\n", lf_last_error(f.est));
        return -1;
    }
    *state = &f;
    return 0;
}

static int group_teardown(void **state) {
    fixture_t *f = (fixture_t *)*state;
    if (!f) return 0; /* the setup failed before handing the fixture over */
    lf_destroy(f->est);
    scene_free(&f->scene);
    scene_result_free(&f->result);
    return 0;
}

#define EXPECT_FAIL(e, call, status, needle)                                                  \
    do {                                                                                      \
        const int32_t st_ = (call);                                                           \
        if (st_ != (status)) fail_msg("%s: status %d, expected %d (%s)", #call, (int)st_,     \
                                      (int)(status), lf_last_error(e));                       \
        if (!strstr(lf_last_error(e), (needle)))                                              \
            fail_msg("%s: message '%s' lacks '%s'", #call, lf_last_error(e), (needle));       \
    } while (0)

static void test_not_ready(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_estimator_t *e = new_estimator(&f->scene, 1, NULL);
    assert_non_null(e);
    lf_result_info_t info;
    lf_result_info_init(&info);
    lf_result_buffers_t b;
    lf_result_buffers_init(&b);
    lf_result_views_t v;
    lf_result_views_init(&v);
    lf_points3d_buffers_t p;
    lf_points3d_buffers_init(&p);
    const char *name = NULL;
    EXPECT_FAIL(e, lf_get_result_info(e, &info), LF_ERR_NOT_READY, "no result yet");
    EXPECT_FAIL(e, lf_get_result(e, &b), LF_ERR_NOT_READY, "no result yet");
    EXPECT_FAIL(e, lf_get_result_views(e, &v), LF_ERR_NOT_READY, "no result yet");
    EXPECT_FAIL(e, lf_get_points3d(e, &p), LF_ERR_NOT_READY, "no result yet");
    EXPECT_FAIL(e, lf_get_timing(e, 0, &name, NULL), LF_ERR_NOT_READY, "no result yet");
    assert_null(name);
    lf_ego_motion_t ego;
    lf_ego_motion_init(&ego);
    lf_object_motion_buffers_t om;
    lf_object_motion_buffers_init(&om);
    EXPECT_FAIL(e, lf_get_ego_motion(e, &ego), LF_ERR_NOT_READY, "no result yet");
    EXPECT_FAIL(e, lf_get_object_motion(e, &om), LF_ERR_NOT_READY, "no result yet");
    EXPECT_FAIL(NULL, lf_get_ego_motion(NULL, &ego), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    EXPECT_FAIL(NULL, lf_get_object_motion(NULL, &om), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    assert_int_equal(lf_has_result(e), 0);
    assert_int_equal(lf_has_result(NULL), 0);
    EXPECT_FAIL(NULL, lf_get_result_info(NULL, &info), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    EXPECT_FAIL(NULL, lf_get_result(NULL, &b), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    EXPECT_FAIL(NULL, lf_get_result_views(NULL, &v), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    EXPECT_FAIL(NULL, lf_get_points3d(NULL, &p), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    EXPECT_FAIL(NULL, lf_get_timing(NULL, 0, NULL, NULL), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    lf_destroy(e);
}

static void test_info_and_timings(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_estimator_t *e = f->est;
    lf_result_info_t info;
    lf_result_info_init(&info);
    assert_int_equal(lf_get_result_info(e, &info), LF_OK);
    assert_int_equal(info.struct_size, sizeof info);
    assert_int_equal(info.width, W);
    assert_int_equal(info.height, H);
    assert_int_equal(info.last_stage, LF_STAGE_INTERPOLATION);
    assert_true(info.t0_us == 0 && info.t1_us == 100000);
    assert_true(info.timing_count >= 4);
    assert_true(info.total_seconds > 0);
    double sum = 0;
    int saw_interpolation = 0;
    for (uint32_t i = 0; i < info.timing_count; ++i) {
        const char *name = NULL;
        double sec = -1;
        assert_int_equal(lf_get_timing(e, i, &name, &sec), LF_OK);
        assert_non_null(name);
        assert_true(strlen(name) > 0 && sec >= 0);
        sum += sec;
        saw_interpolation |= strcmp(name, "interpolation") == 0;
    }
    assert_true(saw_interpolation);
    assert_true(sum <= info.total_seconds * 1.01 + 1e-3);
    assert_int_equal(lf_get_timing(e, 0, NULL, NULL), LF_OK);
    EXPECT_FAIL(e, lf_get_timing(e, info.timing_count, NULL, NULL), LF_ERR_INVALID_ARGUMENT, "out of range");

    EXPECT_FAIL(e, lf_get_result_info(e, NULL), LF_ERR_INVALID_ARGUMENT, "info is NULL");
    info.struct_size = 4;
    EXPECT_FAIL(e, lf_get_result_info(e, &info), LF_ERR_INVALID_ARGUMENT, "info.struct_size is 4");

    /* A caller built against the first layout: its fields are filled, nothing after them. */
    unsigned char old[sizeof(lf_result_info_t) + 8];
    memset(old, 0xAB, sizeof old);
    lf_result_info_t *v1 = (lf_result_info_t *)(void *)old;
    v1->struct_size = LF_RESULT_INFO_V1_SIZE;
    assert_int_equal(lf_get_result_info(e, v1), LF_OK);
    assert_int_equal(v1->width, W);
    assert_true(v1->total_seconds > 0);
    for (size_t i = LF_RESULT_INFO_V1_SIZE; i < sizeof old; ++i) assert_int_equal(old[i], 0xAB);
    assert_int_equal(LF_RESULT_INFO_V1_SIZE, offsetof(lf_result_info_t, rectified));
}

/* Copies into padded planes; bad buffers are rejected before anything is written. */
static void test_copy_into_strided_planes(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_estimator_t *e = f->est;
    enum { FS = W + 5, BS = W + 3 }; /* floats per row, bytes per row of the valid plane */
    static float u[FS * H], d1[FS * H];
    static uint8_t valid[BS * H];
    memset(u, 0xCD, sizeof u);
    memset(d1, 0xCD, sizeof d1);
    memset(valid, 0xCD, sizeof valid);
    lf_result_buffers_t b;
    lf_result_buffers_init(&b);
    b.width = W;
    b.height = H;
    b.u.data = u;
    b.u.stride_bytes = FS * sizeof(float);
    b.d1.data = d1;
    b.d1.stride_bytes = FS * sizeof(float);
    b.valid.data = valid;
    b.valid.stride_bytes = BS;

    lf_result_buffers_t bad = b;
    bad.width = W + 1;
    EXPECT_FAIL(e, lf_get_result(e, &bad), LF_ERR_SIZE_MISMATCH, "buffers are 161x64, the result is 160x64");
    bad = b;
    bad.height = 0;
    EXPECT_FAIL(e, lf_get_result(e, &bad), LF_ERR_SIZE_MISMATCH, "160x0");
    bad = b;
    bad.d1.stride_bytes = W * sizeof(float) - 1;
    EXPECT_FAIL(e, lf_get_result(e, &bad), LF_ERR_SIZE_MISMATCH, "d1.stride_bytes 639");
    bad = b;
    bad.valid.stride_bytes = 0;
    EXPECT_FAIL(e, lf_get_result(e, &bad), LF_ERR_SIZE_MISMATCH, "valid.stride_bytes 0");
    bad = b;
    bad.struct_size = 0;
    EXPECT_FAIL(e, lf_get_result(e, &bad), LF_ERR_INVALID_ARGUMENT, "buffers.struct_size is 0");
    EXPECT_FAIL(e, lf_get_result(e, NULL), LF_ERR_INVALID_ARGUMENT, "buffers is NULL");
    for (size_t i = 0; i < sizeof valid; ++i) assert_int_equal(valid[i], 0xCD); /* untouched */

    assert_int_equal(lf_get_result(e, &b), LF_OK);
    assert_string_equal(lf_last_error(e), "");
    for (int y = 0; y < H; ++y) {
        assert_memory_equal(u + y * FS, f->result.u + y * W, W * sizeof(float));
        assert_memory_equal(d1 + y * FS, f->result.d1 + y * W, W * sizeof(float));
        assert_memory_equal(valid + y * BS, f->result.valid + y * W, W);
        for (int x = W; x < FS; ++x) assert_int_equal(((uint8_t *)(u + y * FS + x))[0], 0xCD); /* padding kept */
        for (int x = W; x < BS; ++x) assert_int_equal(valid[y * BS + x], 0xCD);
    }
    /* The dense result is valid everywhere. */
    for (int i = 0; i < W * H; ++i) assert_int_equal(f->result.valid[i], 1);
}

static void test_views_borrow_the_result(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_estimator_t *e = f->est;
    lf_result_views_t v;
    lf_result_views_init(&v);
    assert_int_equal(lf_get_result_views(e, &v), LF_OK);
    assert_int_equal(v.width, W);
    assert_int_equal(v.height, H);
    const lf_view_t *planes[5] = {&v.u, &v.v, &v.d0, &v.d1, &v.confidence};
    const float *copies[5] = {f->result.u, f->result.v, f->result.d0, f->result.d1, f->result.confidence};
    for (int k = 0; k < 5; ++k) {
        assert_non_null(planes[k]->data);
        assert_true(planes[k]->stride_bytes >= W * sizeof(float));
        for (int y = 0; y < H; ++y)
            assert_memory_equal((const uint8_t *)planes[k]->data + y * planes[k]->stride_bytes, copies[k] + y * W,
                                W * sizeof(float));
    }
    for (int y = 0; y < H; ++y)
        assert_memory_equal((const uint8_t *)v.valid.data + y * v.valid.stride_bytes, f->result.valid + y * W, W);
    EXPECT_FAIL(e, lf_get_result_views(e, NULL), LF_ERR_INVALID_ARGUMENT, "views is NULL");
    v.struct_size = 3;
    EXPECT_FAIL(e, lf_get_result_views(e, &v), LF_ERR_INVALID_ARGUMENT, "struct_size");
}

/* Packed W x H planes for lf_get_points3d (12 bytes per pixel for points and motion). */
static lf_points3d_buffers_t packed_points3d(float *pts, float *mot, uint8_t *valid) {
    lf_points3d_buffers_t b;
    lf_points3d_buffers_init(&b);
    b.width = W;
    b.height = H;
    b.points.data = pts;
    b.points.stride_bytes = W * 12;
    b.motion.data = mot;
    b.motion.stride_bytes = W * 12;
    b.valid.data = valid;
    b.valid.stride_bytes = W;
    return b;
}

static void test_points3d(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_estimator_t *e = f->est;
    const lf_calibration_t c = scene_calibration(&f->scene);
    static float pts[W * H * 3], mot[W * H * 3];
    static uint8_t valid[W * H];
    lf_points3d_buffers_t b = packed_points3d(pts, mot, valid);
    lf_points3d_buffers_t bad = b;
    bad.points.stride_bytes = W * 4; /* a float plane's stride: rows hold 12 bytes per pixel */
    EXPECT_FAIL(e, lf_get_points3d(e, &bad), LF_ERR_SIZE_MISMATCH, "points.stride_bytes 640");
    bad = b;
    bad.width = 10;
    EXPECT_FAIL(e, lf_get_points3d(e, &bad), LF_ERR_SIZE_MISMATCH, "buffers are 10x64");
    EXPECT_FAIL(e, lf_get_points3d(e, NULL), LF_ERR_INVALID_ARGUMENT, "buffers is NULL");
    assert_int_equal(lf_get_points3d(e, &b), LF_OK);

    const scene_result_t *r = &f->result;
    int near_truth = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const int i = y * W + x;
            assert_int_equal(valid[i], r->valid[i] && r->d0[i] > 0 && r->d1[i] > 0);
            if (!valid[i]) continue;
            /* The documented formulas, from the 2-D result. */
            const double z0 = c.fx * c.baseline / r->d0[i], z1 = c.fx * c.baseline / r->d1[i];
            const double x0 = (x - c.cx) * z0 / c.fx, y0 = (y - c.cy) * z0 / c.fy;
            const double x1 = (x + r->u[i] - c.cx) * z1 / c.fx, y1 = (y + r->v[i] - c.cy) * z1 / c.fy;
            const double want[6] = {x0, y0, z0, x1 - x0, y1 - y0, z1 - z0};
            const float got[6] = {pts[3 * i], pts[3 * i + 1], pts[3 * i + 2], mot[3 * i], mot[3 * i + 1], mot[3 * i + 2]};
            for (int k = 0; k < 6; ++k)
                if (fabs(got[k] - want[k]) > 1e-5 * (1 + fabs(want[k])))
                    fail_msg("(%d, %d)[%d]: %.7g, expected %.7g", x, y, k, got[k], want[k]);
            /* Truth: the plane at z = 5 m moved by (3, 1) px at constant depth. */
            near_truth += fabsf(pts[3 * i + 2] - 5.0f) < 0.5f && fabsf(mot[3 * i] - 0.15f) < 0.05f &&
                          fabsf(mot[3 * i + 1] - 0.05f) < 0.05f && fabsf(mot[3 * i + 2]) < 0.5f;
        }
    assert_true(near_truth > 0.95 * W * H);

    /* Only the valid plane. */
    lf_points3d_buffers_t only_valid;
    lf_points3d_buffers_init(&only_valid);
    only_valid.width = W;
    only_valid.height = H;
    only_valid.valid.data = valid;
    only_valid.valid.stride_bytes = W;
    assert_int_equal(lf_get_points3d(e, &only_valid), LF_OK);
}

/* A LiDAR disparity of 1e-40 px is accepted (in [0, 16384]) and the result keeps it, but its
 * depth fx * baseline / d = 5e41 m fits no float: such pixels are not valid 3-D points (they
 * were valid with z = inf). Every valid point is finite. */
static void test_points3d_beyond_float_range(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    lf_estimator_t *e = new_estimator(s, 1, NULL);
    assert_non_null(e);
    float xyz[3 * 64];
    const uint32_t n = scene_lidar(s, 16, xyz);
    xyz[3 * 5 + 2] = 1e-40f;
    const lf_lidar_t lidar = {LF_LIDAR_DISPARITY, n, xyz, 0};
    const lf_image_t l0 = scene_image(s->left0, W, H), r0 = scene_image(s->right0, W, H);
    const lf_image_t l1 = scene_image(s->left1, W, H), r1 = scene_image(s->right1, W, H);
    if (lf_push_frame(e, 0, &l0, &r0, &lidar) != LF_OK || lf_push_frame(e, 1, &l1, &r1, &lidar) != LF_OK)
        fail_msg("push: %s", lf_last_error(e));
    scene_result_t r;
    assert_int_equal(scene_result_fetch(e, &r), LF_OK);
    static float pts[W * H * 3], mot[W * H * 3];
    static uint8_t valid[W * H];
    lf_points3d_buffers_t b = packed_points3d(pts, mot, valid);
    assert_int_equal(lf_get_points3d(e, &b), LF_OK);
    int tiny = 0;
    for (int i = 0; i < W * H; ++i) {
        const int far = r.valid[i] && r.d0[i] > 0 && r.d0[i] < 1e-30f;
        tiny += far;
        if (far) {
            assert_int_equal(valid[i], 0);
            assert_true(isnan(pts[3 * i + 2]) && isnan(mot[3 * i + 2]));
        }
        if (!valid[i]) continue;
        for (int k = 0; k < 3; ++k) assert_true(isfinite(pts[3 * i + k]) && isfinite(mot[3 * i + k]));
    }
    /* The LiDAR pixel itself keeps its value (interpolation.keep_lidar_values), so the case is
     * exercised, not assumed. */
    assert_true(tiny >= 1);
    scene_result_free(&r);
    lf_destroy(e);
}

/* The scene is one plane at 5 m moved by (3, 1) px: a rigid motion of the whole view. The
 * ego-motion explains it, so the object motion is about 0 wherever the result is right. */
static void test_ego_motion(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_estimator_t *e = f->est;
    lf_ego_motion_t ego;
    lf_ego_motion_init(&ego);
    EXPECT_FAIL(e, lf_get_ego_motion(e, NULL), LF_ERR_INVALID_ARGUMENT, "ego is NULL");
    ego.struct_size = 8;
    EXPECT_FAIL(e, lf_get_ego_motion(e, &ego), LF_ERR_INVALID_ARGUMENT, "struct_size");
    lf_ego_motion_init(&ego);
    assert_int_equal(lf_get_ego_motion(e, &ego), LF_OK);
    assert_int_equal(ego.state, LF_EGO_OK);
    assert_int_equal(ego.struct_size, sizeof ego);
    assert_true(ego.inliers > 0.5 * ego.candidates && ego.candidates > 0);
    const double *T = ego.transform;
    assert_true(T[12] == 0 && T[13] == 0 && T[14] == 0 && T[15] == 1);
    /* T moves the plane's centre pixel point (0, 0, 5) m by the scene's (3, 1) px at 5 m depth. */
    const double X = T[3] + 5 * T[2], Y = T[7] + 5 * T[6], Z = T[11] + 5 * T[10];
    assert_true(fabs(100 * X / Z - 3) < 0.3 && fabs(100 * Y / Z - 1) < 0.3 && fabs(Z - 5) < 0.3);

    static float om[W * H * 3];
    static uint8_t valid[W * H];
    lf_object_motion_buffers_t b;
    lf_object_motion_buffers_init(&b);
    b.width = W;
    b.height = H;
    b.motion.data = om;
    b.motion.stride_bytes = W * 12;
    b.valid.data = valid;
    b.valid.stride_bytes = W;
    lf_object_motion_buffers_t bad = b;
    bad.motion.stride_bytes = W * 4;
    EXPECT_FAIL(e, lf_get_object_motion(e, &bad), LF_ERR_SIZE_MISMATCH, "motion.stride_bytes 640");
    bad = b;
    bad.height = 3;
    EXPECT_FAIL(e, lf_get_object_motion(e, &bad), LF_ERR_SIZE_MISMATCH, "buffers are 160x3");
    EXPECT_FAIL(e, lf_get_object_motion(e, NULL), LF_ERR_INVALID_ARGUMENT, "buffers is NULL");
    bad = b;
    bad.struct_size = 4;
    EXPECT_FAIL(e, lf_get_object_motion(e, &bad), LF_ERR_INVALID_ARGUMENT, "struct_size");
    assert_int_equal(lf_get_object_motion(e, &b), LF_OK);

    static float pts[W * H * 3], mot[W * H * 3];
    static uint8_t valid3d[W * H];
    lf_points3d_buffers_t p = packed_points3d(pts, mot, valid3d);
    assert_int_equal(lf_get_points3d(e, &p), LF_OK);
    int still = 0;
    for (int i = 0; i < W * H; ++i) {
        assert_int_equal(valid[i], valid3d[i]);
        if (!valid[i]) {
            assert_true(isnan(om[3 * i]) && isnan(om[3 * i + 1]) && isnan(om[3 * i + 2]));
            continue;
        }
        /* The documented formula, X1 - T X0, from lf_get_points3d's X0 and X1 = X0 + motion. */
        for (int k = 0; k < 3; ++k) {
            const double x1 = (double)pts[3 * i + k] + mot[3 * i + k];
            const double tx = T[4 * k] * pts[3 * i] + T[4 * k + 1] * pts[3 * i + 1] + T[4 * k + 2] * pts[3 * i + 2] +
                              T[4 * k + 3];
            if (fabs(om[3 * i + k] - (x1 - tx)) > 1e-4 * (1 + fabs(x1)))
                fail_msg("pixel %d [%d]: %.7g, expected %.7g", i, k, om[3 * i + k], x1 - tx);
        }
        still += om[3 * i] * om[3 * i] + om[3 * i + 1] * om[3 * i + 1] + om[3 * i + 2] * om[3 * i + 2] < 0.02f * 0.02f;
    }
    assert_true(still > 0.9 * W * H);
}

/* Without stage 4 there is no fit: a state says so, the transform is the identity and the
 * object motion is refused with the reason. */
static void test_ego_motion_not_run(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_options_t *o = scene_options(1);
    assert_int_equal(lf_options_set_string(o, "last_stage", "sparse"), LF_OK);
    lf_calibration_t c = scene_calibration(&f->scene);
    lf_estimator_t *e = NULL;
    assert_int_equal(lf_create(o, &c, &e), LF_OK);
    lf_options_destroy(o);
    assert_int_equal(scene_push_pair(e, &f->scene, 0, 1), LF_OK);
    lf_ego_motion_t ego;
    lf_ego_motion_init(&ego);
    assert_int_equal(lf_get_ego_motion(e, &ego), LF_OK);
    assert_int_equal(ego.state, LF_EGO_NOT_RUN);
    for (int k = 0; k < 16; ++k) assert_true(ego.transform[k] == (k % 5 == 0 ? 1.0 : 0.0));
    assert_int_equal(ego.inliers, 0);
    assert_int_equal(ego.candidates, 0);
    static float om[W * H * 3];
    lf_object_motion_buffers_t b;
    lf_object_motion_buffers_init(&b);
    b.width = W;
    b.height = H;
    b.motion.data = om;
    b.motion.stride_bytes = W * 12;
    om[0] = 42.0f;
    EXPECT_FAIL(e, lf_get_object_motion(e, &b), LF_ERR_BAD_STATE, "before interpolation");
    assert_true(om[0] == 42.0f); /* nothing written */
    lf_destroy(e);
}

/* Creates an estimator from `o` (destroyed here) and pushes the scene's pair into it. */
static lf_estimator_t *create_and_push(lf_options_t *o, const scene_t *s) {
    lf_calibration_t c = scene_calibration(s);
    lf_estimator_t *e = NULL;
    assert_int_equal(lf_create(o, &c, &e), LF_OK);
    lf_options_destroy(o);
    assert_int_equal(scene_push_pair(e, s, 0, 1), LF_OK);
    return e;
}

/* Stopping after the sparsification: a sparse result with NaN (confidence 0) where invalid, and NaN points. */
static void test_sparse_stage(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_options_t *o = scene_options(1);
    assert_int_equal(lf_options_set_string(o, "last_stage", "sparse"), LF_OK);
    lf_estimator_t *e = create_and_push(o, &f->scene);
    lf_result_info_t info;
    lf_result_info_init(&info);
    assert_int_equal(lf_get_result_info(e, &info), LF_OK);
    assert_int_equal(info.last_stage, LF_STAGE_SPARSE);
    scene_result_t r;
    assert_int_equal(scene_result_fetch(e, &r), LF_OK);
    static float pts[W * H * 3];
    lf_points3d_buffers_t b;
    lf_points3d_buffers_init(&b);
    b.width = W;
    b.height = H;
    b.points.data = pts;
    b.points.stride_bytes = W * 12;
    assert_int_equal(lf_get_points3d(e, &b), LF_OK);
    int n_valid = 0;
    for (int i = 0; i < W * H; ++i) {
        if (r.valid[i]) {
            ++n_valid;
            assert_true(isfinite(pts[3 * i + 2]));
            continue;
        }
        assert_true(isnan(r.u[i]) && isnan(r.v[i]) && isnan(r.d0[i]) && isnan(r.d1[i]) && r.confidence[i] == 0);
        assert_true(isnan(pts[3 * i]) && isnan(pts[3 * i + 1]) && isnan(pts[3 * i + 2]));
    }
    /* sparsified on 3x3 blocks: at most one match per block, and some survive */
    assert_true(n_valid > 0 && n_valid <= (W / 3 + 1) * (H / 3 + 1));
    assert_true(scene_result_accuracy(&r, 3, 1, 10) * W * H > 0.95 * n_valid);
    scene_result_free(&r);
    lf_destroy(e);
}

/* "processing_scale" 0.5: the estimator works at half size and the result comes back at the
 * input size, dense and about as accurate on this plane scene. */
static void test_half_resolution(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_options_t *o = scene_options(1);
    assert_int_equal(lf_options_set_float(o, "processing_scale", 0.5), LF_OK);
    lf_estimator_t *e = create_and_push(o, &f->scene);
    lf_result_info_t info;
    lf_result_info_init(&info);
    assert_int_equal(lf_get_result_info(e, &info), LF_OK);
    assert_int_equal(info.width, W);
    assert_int_equal(info.height, H);
    scene_result_t r;
    assert_int_equal(scene_result_fetch(e, &r), LF_OK);
    int n_valid = 0;
    for (int i = 0; i < W * H; ++i) n_valid += r.valid[i] != 0;
    assert_int_equal(n_valid, W * H);
    /* Matches are whole pixels of the half-size image, i.e. 2 px steps here: judge by the
     * KITTI outlier threshold (3 px) instead of scene_result_accuracy's 1 px. */
    int good = 0;
    for (int i = 0; i < W * H; ++i) {
        const float e0 = r.d0[i] - 10, e1 = r.d1[i] - 10, eu = r.u[i] - 3, ev = r.v[i] - 1;
        good += e0 * e0 < 9 && e1 * e1 < 9 && eu * eu + ev * ev < 9;
    }
    printf("within 3 px at half resolution: %.3f (within 1 px: %.3f)\n", (double)good / (W * H),
           scene_result_accuracy(&r, 3, 1, 10));
    assert_true(good > 0.95 * W * H);
    scene_result_free(&r);
    lf_destroy(e);
}

/* The same LiDAR as disparities, camera-frame points and LiDAR-frame points (strided like
 * KITTI's x, y, z, reflectance) must become the same measurements. They are made visible by
 * a LiDAR that disagrees with the images (disparity 12.5, z = 4 m, where the plane is at
 * 10 px): the output keeps LiDAR values at their pixels ("interpolation.keep_lidar_values"). */
static void test_lidar_kinds_agree(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    lf_calibration_t c = scene_calibration(s);
    /* LiDAR axes as KITTI's Velodyne: x forward, y left, z up; mounted 1 m behind, 0.25 m
     * right of and 0.5 m above the camera: camera = T * lidar. All entries exact in binary. */
    static const double T[16] = {0, -1, 0, 0.25, 0, 0, -1, -0.5, 1, 0, 0, 1.0, 0, 0, 0, 1};
    c.has_lidar_to_camera = 1;
    memcpy(c.lidar_to_camera, T, sizeof T);

    float disp[3 * 64], cam[4 * 64], lid[4 * 64];
    const uint32_t n = scene_lidar(s, 16, disp);
    for (uint32_t i = 0; i < n; ++i) {
        disp[3 * i + 2] = 12.5f;
        const double z = c.fx * c.baseline / disp[3 * i + 2]; /* 4 m */
        const double X = (disp[3 * i] - c.cx) * z / c.fx, Y = (disp[3 * i + 1] - c.cy) * z / c.fy;
        cam[4 * i] = (float)X;
        cam[4 * i + 1] = (float)Y;
        cam[4 * i + 2] = (float)z;
        cam[4 * i + 3] = 0.5f;
        lid[4 * i] = (float)(z - 1.0); /* T^-1 */
        lid[4 * i + 1] = (float)(-(X - 0.25));
        lid[4 * i + 2] = (float)(-(Y + 0.5));
        lid[4 * i + 3] = 0.5f;
    }
    const lf_lidar_t kinds[3] = {{LF_LIDAR_DISPARITY, n, disp, 0},
                                 {LF_LIDAR_POINTS_CAMERA, n, cam, 16},
                                 {LF_LIDAR_POINTS_LIDAR, n, lid, 16}};
    const lf_image_t l0 = scene_image(s->left0, W, H), r0 = scene_image(s->right0, W, H);
    const lf_image_t l1 = scene_image(s->left1, W, H), r1 = scene_image(s->right1, W, H);
    scene_result_t first;
    memset(&first, 0, sizeof first);
    for (int k = 0; k < 3; ++k) {
        lf_options_t *o = scene_options(1);
        assert_int_equal(lf_options_set_int(o, "interpolation.keep_lidar_values", 1), LF_OK);
        lf_estimator_t *e = NULL;
        assert_int_equal(lf_create(o, &c, &e), LF_OK);
        lf_options_destroy(o);
        assert_int_equal(lf_push_frame(e, 0, &l0, &r0, &kinds[k]), LF_OK);
        assert_int_equal(lf_push_frame(e, 100000, &l1, &r1, &kinds[k]), LF_OK);
        scene_result_t r;
        assert_int_equal(scene_result_fetch(e, &r), LF_OK);
        for (uint32_t i = 0; i < n; ++i) {
            const int x = (int)disp[3 * i], y = (int)disp[3 * i + 1];
            if (r.d0[y * W + x] != 12.5f) fail_msg("kind %d: d0 at LiDAR pixel (%d, %d) is %.7g", kinds[k].kind, x, y,
                                                   r.d0[y * W + x]);
        }
        if (k == 0) {
            first = r;
        } else {
            if (!scene_result_equal(&r, &first)) fail_msg("LiDAR kind %d differs from the disparity list", kinds[k].kind);
            scene_result_free(&r);
        }
        lf_destroy(e);
    }
    /* The measurements matter: the result is not the LiDAR-free one. */
    assert_false(scene_result_equal(&first, &f->result));
    scene_result_free(&first);
}

/* The LiDAR pushed with the first frame is D_l^0 of the pair (it pins d0 at its pixels in the
 * reference image); pushed with the second frame it is D_l^1, which lives in I_l^1 and does
 * not. Disparity 12.5 disagrees with the images (10) to make that visible. */
static void test_lidar_goes_with_its_frame(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    float disp[3 * 64];
    const uint32_t n = scene_lidar(s, 16, disp);
    for (uint32_t i = 0; i < n; ++i) disp[3 * i + 2] = 12.5f;
    const lf_lidar_t lidar = {LF_LIDAR_DISPARITY, n, disp, 0};
    const lf_image_t l0 = scene_image(s->left0, W, H), r0 = scene_image(s->right0, W, H);
    const lf_image_t l1 = scene_image(s->left1, W, H), r1 = scene_image(s->right1, W, H);
    for (int with_first = 1; with_first >= 0; --with_first) {
        lf_estimator_t *e = new_estimator(s, 1, NULL);
        assert_int_equal(lf_push_frame(e, 0, &l0, &r0, with_first ? &lidar : NULL), LF_OK);
        assert_int_equal(lf_push_frame(e, 1, &l1, &r1, with_first ? NULL : &lidar), LF_OK);
        scene_result_t r;
        assert_int_equal(scene_result_fetch(e, &r), LF_OK);
        uint32_t pinned = 0;
        for (uint32_t i = 0; i < n; ++i) pinned += r.d0[(int)disp[3 * i + 1] * W + (int)disp[3 * i]] == 12.5f;
        if (with_first) assert_int_equal(pinned, n);
        else assert_int_equal(pinned, 0);
        scene_result_free(&r);
        lf_destroy(e);
    }
}

/* RGB and BGR buffers of the same colours give the same result, and declaring the wrong
 * order changes it (one channel is independent noise, so the order matters); 1 and 3 threads
 * give the same result. */
static void test_colour_orders_and_threads_agree(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    static uint8_t rgb[4][W * H * 3], bgr[4][W * H * 3];
    const uint8_t *gray[4] = {s->left0, s->right0, s->left1, s->right1};
    for (int k = 0; k < 4; ++k)
        for (int i = 0; i < W * H; ++i) {
            const uint8_t g = gray[k][i];
            const uint8_t channels[3] = {g, (uint8_t)(255 - g), (uint8_t)(scene_hash((uint32_t)i, (uint32_t)k, 99) & 255u)};
            for (int ch = 0; ch < 3; ++ch) {
                rgb[k][3 * i + ch] = channels[ch];
                bgr[k][3 * i + 2 - ch] = channels[ch];
            }
        }
    scene_result_t results[3];
    for (int run = 0; run < 3; ++run) {
        /* run 0: RGB as RGB; 1: BGR as BGR; 2: RGB bytes declared BGR */
        lf_image_t im[4];
        for (int k = 0; k < 4; ++k) {
            im[k] = scene_image(run == 1 ? bgr[k] : rgb[k], W, H);
            im[k].stride_bytes = 3 * W;
            im[k].format = run == 0 ? LF_PIXEL_RGB8 : LF_PIXEL_BGR8;
        }
        lf_estimator_t *e = new_estimator(s, 1, NULL);
        assert_int_equal(lf_push_frame(e, 0, &im[0], &im[1], NULL), LF_OK);
        assert_int_equal(lf_push_frame(e, 1, &im[2], &im[3], NULL), LF_OK);
        assert_int_equal(scene_result_fetch(e, &results[run]), LF_OK);
        lf_destroy(e);
    }
    assert_true(scene_result_equal(&results[0], &results[1]));
    assert_false(scene_result_equal(&results[0], &results[2]));
    for (int run = 0; run < 3; ++run) scene_result_free(&results[run]);

    lf_estimator_t *e = new_estimator(s, 3, NULL);
    assert_int_equal(scene_push_pair(e, s, 0, 1), LF_OK);
    assert_true(scene_result_matches(e, &f->result));
    lf_destroy(e);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_not_ready),
        cmocka_unit_test(test_info_and_timings),
        cmocka_unit_test(test_copy_into_strided_planes),
        cmocka_unit_test(test_views_borrow_the_result),
        cmocka_unit_test(test_points3d),
        cmocka_unit_test(test_points3d_beyond_float_range),
        cmocka_unit_test(test_ego_motion),
        cmocka_unit_test(test_ego_motion_not_run),
        cmocka_unit_test(test_sparse_stage),
        cmocka_unit_test(test_half_resolution),
        cmocka_unit_test(test_lidar_kinds_agree),
        cmocka_unit_test(test_lidar_goes_with_its_frame),
        cmocka_unit_test(test_colour_orders_and_threads_agree),
    };
    return cmocka_run_group_tests_name("capi_results", tests, group_setup, group_teardown);
}
