/* SPDX-License-Identifier: MIT */
/* C ABI: lf_create and lf_push_frame with good and bad arguments. Every bad call must return
 * its documented status with a message, and leave the handle usable and unchanged: the suites
 * end each battery of bad calls with good pushes whose result must equal a clean handle's
 * bit for bit. Compiled as C99 against the public header only. */
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
    scene_result_t reference; /* a clean handle's result on the scene */
} fixture_t;

static int group_setup(void **state) {
    static fixture_t f;
    if (!scene_make(&f.scene, W, H, 10, 3, 1, 7)) return -1;
    lf_options_t *o = scene_options(1);
    lf_calibration_t c = scene_calibration(&f.scene);
    lf_estimator_t *e = NULL;
    if (!o || lf_create(o, &c, &e) != LF_OK) return -1;
    lf_options_destroy(o);
    if (scene_push_pair(e, &f.scene, 0, 1) != LF_OK || scene_result_fetch(e, &f.reference) != LF_OK) {
        fprintf(stderr, "reference run failed: %s\n", lf_last_error(e));
        return -1;
    }
    lf_destroy(e);
    *state = &f;
    return 0;
}

static int group_teardown(void **state) {
    fixture_t *f = (fixture_t *)*state;
    if (!f) return 0; /* the setup failed before handing the fixture over */
    scene_free(&f->scene);
    scene_result_free(&f->reference);
    return 0;
}

static lf_estimator_t *new_estimator(const scene_t *s) {
    lf_options_t *o = scene_options(1);
    lf_calibration_t c = scene_calibration(s);
    lf_estimator_t *e = NULL;
    assert_non_null(o);
    assert_int_equal(lf_create(o, &c, &e), LF_OK);
    lf_options_destroy(o);
    assert_non_null(e);
    return e;
}

/* status and a message that contains `needle`, on the handle and for the thread. */
#define EXPECT_FAIL(e, call, status, needle)                                                  \
    do {                                                                                      \
        const int32_t st_ = (call);                                                           \
        if (st_ != (status)) fail_msg("%s: status %d, expected %d (%s)", #call, (int)st_,     \
                                      (int)(status), lf_last_error(e));                       \
        if (!strstr(lf_last_error(e), (needle)))                                              \
            fail_msg("%s: message '%s' lacks '%s'", #call, lf_last_error(e), (needle));       \
        assert_string_equal(lf_last_error(NULL), lf_last_error(e));                           \
    } while (0)

/* The good pair, then the result must equal the clean handle's. */
static void expect_good_pair(lf_estimator_t *e, fixture_t *f, int64_t t) {
    if (scene_push_pair(e, &f->scene, t, 1) != LF_OK) fail_msg("good push failed: %s", lf_last_error(e));
    assert_string_equal(lf_last_error(e), "");
    assert_true(scene_result_matches(e, &f->reference));
}

static void test_reference_is_accurate(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const double acc = scene_result_accuracy(&f->reference, 3, 1, 10);
    if (acc < 0.95) fail_msg("only %.1f %% of the pixels within 1 px", 100 * acc);
}

static void test_create_arguments(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_calibration_t c = scene_calibration(&f->scene);
    lf_estimator_t *e = (lf_estimator_t *)&c; /* must be overwritten with NULL on failure */

    EXPECT_FAIL(NULL, lf_create(NULL, &c, NULL), LF_ERR_INVALID_ARGUMENT, "out is NULL");
    EXPECT_FAIL(NULL, lf_create(NULL, NULL, &e), LF_ERR_INVALID_ARGUMENT, "calibration is NULL");
    assert_null(e);

    lf_calibration_t bad = c;
    bad.struct_size = 8;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "struct_size");
    bad = c;
    bad.fx = 0;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "fx = 0 px is outside [1, 1e+06]");
    bad = c;
    bad.baseline = -0.5;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "baseline = -0.5 m is outside");
    bad = c;
    bad.cy = NAN;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "cy = nan px is outside");
    bad = c;
    bad.fy = INFINITY;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "fy = inf px is outside");
    /* Finite but absurd: depths fx * baseline / d would overflow or lose every digit. */
    bad = c;
    bad.fx = 1e-300;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "fx = 1e-300 px is outside");
    bad = c;
    bad.fx = bad.baseline = 1e200; /* fx * baseline = inf */
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "fx = 1e+200 px is outside");
    bad.fx = 1e6;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "baseline = 1e+200 m is outside");
    bad = c;
    bad.cx = -2e6;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "cx = -2e+06 px is outside");
    /* The bounds themselves are accepted. */
    bad = c;
    bad.fx = 1;
    bad.fy = 1e6;
    bad.cx = -1e6;
    bad.baseline = 1e4;
    assert_int_equal(lf_create(NULL, &bad, &e), LF_OK);
    lf_destroy(e);
    bad.baseline = 1e-4;
    assert_int_equal(lf_create(NULL, &bad, &e), LF_OK);
    lf_destroy(e);
    e = NULL;
    bad = c;
    bad.has_lidar_to_camera = 2;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "has_lidar_to_camera");
    bad = c;
    bad.has_lidar_to_camera = 1; /* all zero: last row is not 0 0 0 1 */
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "last row");
    bad.lidar_to_camera[0] = bad.lidar_to_camera[5] = bad.lidar_to_camera[10] = bad.lidar_to_camera[15] = 1;
    bad.lidar_to_camera[3] = NAN;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "lidar_to_camera must be finite");
    bad.lidar_to_camera[3] = 0.27;
    assert_int_equal(lf_create(NULL, &bad, &e), LF_OK); /* a rigid transform */
    lf_destroy(e);
    e = NULL;
    for (int i = 0; i < 11; ++i) bad.lidar_to_camera[i] *= 1000; /* millimetres for metres */
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "not a rotation matrix");
    for (int i = 0; i < 11; ++i) bad.lidar_to_camera[i] /= 1000;
    bad.lidar_to_camera[5] = -1; /* a mirror */
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "not a rotation matrix");
    bad.lidar_to_camera[5] = 1;
    bad.lidar_to_camera[7] = 5e4;
    EXPECT_FAIL(NULL, lf_create(NULL, &bad, &e), LF_ERR_INVALID_ARGUMENT, "exceeds 1000 m");
    assert_null(e);

    /* A newer caller's larger struct: accepted when the unknown tail is zero. */
    struct {
        lf_calibration_t c;
        double newer_field;
    } grown;
    memset(&grown, 0, sizeof grown);
    grown.c = c;
    grown.c.struct_size = (uint32_t)sizeof grown;
    assert_int_equal(lf_create(NULL, &grown.c, &e), LF_OK);
    lf_destroy(e);
    grown.newer_field = 1.0;
    EXPECT_FAIL(NULL, lf_create(NULL, &grown.c, &e), LF_ERR_INVALID_ARGUMENT, "non-zero fields");

    /* Options the estimator rejects as a whole. */
    lf_options_t *o = NULL;
    assert_int_equal(lf_options_create(&o), LF_OK);
    assert_int_equal(lf_options_set_int(o, "matching.support_windows", 0), LF_OK);
    EXPECT_FAIL(NULL, lf_create(o, &c, &e), LF_ERR_INVALID_ARGUMENT, "support_window");
    assert_int_equal(lf_options_set_int(o, "matching.support_windows", 1), LF_OK);
    assert_int_equal(lf_options_set_string(o, "interpolation.sed_model", "/nonexistent/sed_model.yml.gz"), LF_OK);
    EXPECT_FAIL(NULL, lf_create(o, &c, &e), LF_ERR_IO, "/nonexistent/sed_model.yml.gz");
    assert_null(e);

    /* NULL options = defaults; the options object may go away after lf_create. */
    assert_int_equal(lf_options_set_string(o, "interpolation.sed_model", ""), LF_OK);
    assert_int_equal(lf_create(o, &c, &e), LF_OK);
    lf_options_destroy(o);
    assert_int_equal(lf_has_result(e), 0);
    lf_destroy(e);
    assert_int_equal(lf_create(NULL, &c, &e), LF_OK);
    lf_destroy(e);
    lf_destroy(NULL);
}

static void test_bad_images(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    lf_estimator_t *e = new_estimator(s);
    const lf_image_t l0 = scene_image(s->left0, W, H), r0 = scene_image(s->right0, W, H);
    lf_image_t bad;

    EXPECT_FAIL(NULL, lf_push_frame(NULL, 0, &l0, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");
    EXPECT_FAIL(e, lf_push_frame(e, 0, NULL, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "left is NULL");
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, NULL, NULL), LF_ERR_INVALID_ARGUMENT, "right is NULL");
    bad = l0;
    bad.data = NULL;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &bad, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "left.data is NULL");
    bad = l0;
    bad.width = 0;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &bad, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "empty");
    bad = r0;
    bad.height = 0;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &bad, NULL), LF_ERR_INVALID_ARGUMENT, "right is 160x0");
    bad = l0;
    bad.width = 20000;
    bad.stride_bytes = 20000;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &bad, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "larger than 16384");
    bad = l0;
    bad.stride_bytes = W - 1;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &bad, &r0, NULL), LF_ERR_SIZE_MISMATCH, "left.stride_bytes 159");
    bad = l0;
    bad.format = 0;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &bad, &bad, NULL), LF_ERR_INVALID_ARGUMENT, "not LF_PIXEL_GRAY8");
    bad = l0;
    bad.format = LF_PIXEL_RGB8; /* gray bytes read as RGB: rows of 160 px need 480 bytes */
    EXPECT_FAIL(e, lf_push_frame(e, 0, &bad, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "different formats");
    EXPECT_FAIL(e, lf_push_frame(e, 0, &bad, &bad, NULL), LF_ERR_SIZE_MISMATCH, "smaller than a row (480 bytes)");
    bad = r0;
    bad.width = W - 2; /* left and right of different sizes */
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &bad, NULL), LF_ERR_SIZE_MISMATCH, "left is 160x64 but right is 158x64");
    assert_int_equal(lf_has_result(e), 0);

    expect_good_pair(e, f, 0);
    lf_destroy(e);
}

static void test_bad_lidar(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    lf_estimator_t *e = new_estimator(s);
    const lf_image_t l0 = scene_image(s->left0, W, H), r0 = scene_image(s->right0, W, H);
    float pts[4][4] = {{10, 10, 10, 0}, {20, 30, 10, 0}, {159.4f, 63.4f, 10, 0}, {0, 0, 0, 0}};
    lf_lidar_t l = {LF_LIDAR_DISPARITY, 3, pts, 16};
    lf_lidar_t bad = l;

    bad.kind = 7;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &bad), LF_ERR_INVALID_ARGUMENT, "lidar.kind 7");
    bad = l;
    bad.data = NULL;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &bad), LF_ERR_INVALID_ARGUMENT, "lidar.data is NULL");
    bad = l;
    bad.stride_bytes = 8;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &bad), LF_ERR_SIZE_MISMATCH, "lidar.stride_bytes 8");
    pts[1][2] = NAN;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &l), LF_ERR_INVALID_ARGUMENT, "lidar entry 1");
    pts[1][2] = INFINITY;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &l), LF_ERR_INVALID_ARGUMENT, "not finite");
    pts[1][2] = 10;
    /* An entry whose nearest pixel lies outside the image is dropped (and logged), as a 3-D
     * point is: one point never costs the frame. */
    static const float near_edge[][2] = {{-0.5f, 30}, {159.4f, 63.4f},                      /* in */
                                         {-0.6f, 30}, {159.6f, 30}, {20, 64}, {1e30f, 30}}; /* dropped */
    for (size_t k = 0; k < sizeof near_edge / sizeof near_edge[0]; ++k) {
        pts[1][0] = near_edge[k][0];
        pts[1][1] = near_edge[k][1];
        assert_int_equal(lf_push_frame(e, 0, &l0, &r0, &l), LF_OK);
        assert_int_equal(lf_reset(e), LF_OK);
    }
    pts[1][0] = 20;
    pts[1][1] = 30;
    pts[1][2] = -1;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &l), LF_ERR_INVALID_ARGUMENT, "disparity outside [0, 16384]");
    pts[1][2] = 3e38f; /* finite, but overflowed the matcher's float -> int conversions */
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &l), LF_ERR_INVALID_ARGUMENT, "disparity outside [0, 16384]");
    pts[1][2] = 16384.5f;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &l), LF_ERR_INVALID_ARGUMENT, "disparity outside [0, 16384]");
    pts[1][2] = 10;
    /* 3-D points: non-finite coordinates are errors ... */
    bad = l;
    bad.kind = LF_LIDAR_POINTS_CAMERA;
    pts[2][0] = NAN;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &bad), LF_ERR_INVALID_ARGUMENT, "lidar entry 2");
    pts[2][0] = 159.4f;
    /* ... the LiDAR frame needs the transform, which this calibration lacks */
    bad.kind = LF_LIDAR_POINTS_LIDAR;
    EXPECT_FAIL(e, lf_push_frame(e, 0, &l0, &r0, &bad), LF_ERR_INVALID_ARGUMENT, "lidar_to_camera");
    assert_int_equal(lf_has_result(e), 0);

    /* Good LiDAR lists of every kind are accepted: points outside the view are dropped. */
    bad.kind = LF_LIDAR_POINTS_CAMERA; /* (10, 10, 10) etc. in metres: partly outside the view */
    assert_int_equal(lf_push_frame(e, 0, &l0, &r0, &bad), LF_OK);
    assert_int_equal(lf_reset(e), LF_OK);
    assert_int_equal(lf_push_frame(e, 0, &l0, &r0, &l), LF_OK); /* corners rounding inside */
    assert_int_equal(lf_reset(e), LF_OK);
    bad.count = 0;
    bad.data = NULL;
    assert_int_equal(lf_push_frame(e, 0, &l0, &r0, &bad), LF_OK); /* empty list */
    assert_int_equal(lf_reset(e), LF_OK);

    expect_good_pair(e, f, 0);
    lf_destroy(e);
}

static void test_sequence_rules(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    lf_estimator_t *e = new_estimator(s);
    const lf_image_t l0 = scene_image(s->left0, W, H), r0 = scene_image(s->right0, W, H);
    uint8_t rgb[W * H * 3];
    memset(rgb, 128, sizeof rgb);
    lf_image_t colour = scene_image(rgb, W, H);
    colour.format = LF_PIXEL_RGB8;
    colour.stride_bytes = 3 * W;
    lf_image_t smaller = scene_image(s->left0, W - 16, H);
    smaller.stride_bytes = W;

    assert_int_equal(lf_push_frame(e, 1000, &l0, &r0, NULL), LF_OK);
    EXPECT_FAIL(e, lf_push_frame(e, 1000, &l0, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "not after the previous frame");
    EXPECT_FAIL(e, lf_push_frame(e, -5, &l0, &r0, NULL), LF_ERR_INVALID_ARGUMENT, "timestamp -5 us");
    EXPECT_FAIL(e, lf_push_frame(e, 2000, &smaller, &smaller, NULL), LF_ERR_SIZE_MISMATCH,
                "144x64 but the previous frame was 160x64");
    EXPECT_FAIL(e, lf_push_frame(e, 2000, &colour, &colour, NULL), LF_ERR_SIZE_MISMATCH, "colour");
    assert_int_equal(lf_has_result(e), 0);

    /* Results before two frames. */
    lf_result_info_t info;
    lf_result_info_init(&info);
    EXPECT_FAIL(e, lf_get_result_info(e, &info), LF_ERR_NOT_READY, "one frame pushed");
    assert_int_equal(lf_reset(e), LF_OK);
    EXPECT_FAIL(e, lf_get_result_info(e, &info), LF_ERR_NOT_READY, "push two frames first");

    /* After a reset any size, format and timestamp starts a new sequence. */
    assert_int_equal(lf_push_frame(e, 5, &smaller, &smaller, NULL), LF_OK);
    assert_int_equal(lf_reset(e), LF_OK);
    assert_int_equal(lf_push_frame(e, 4, &colour, &colour, NULL), LF_OK);
    assert_int_equal(lf_reset(e), LF_OK);
    EXPECT_FAIL(NULL, lf_reset(NULL), LF_ERR_INVALID_ARGUMENT, "estimator is NULL");

    expect_good_pair(e, f, -1000000);
    lf_destroy(e);
}

/* A failure inside the pipeline (featureless images: nothing survives the checks) leaves the
 * previous frame and the previous result in place. */
static void test_pipeline_failure_keeps_state(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    lf_estimator_t *e = new_estimator(s);
    assert_int_equal(scene_push_pair(e, s, 0, 1), LF_OK);
    lf_result_views_t before, after;
    lf_result_views_init(&before);
    lf_result_views_init(&after);
    assert_int_equal(lf_get_result_views(e, &before), LF_OK);

    static uint8_t flat[W * H];
    memset(flat, 90, sizeof flat);
    const lf_image_t fl = scene_image(flat, W, H);
    const int32_t st = lf_push_frame(e, 200000, &fl, &fl, NULL);
    assert_int_not_equal(st, LF_OK);
    assert_int_not_equal(st, LF_ERR_INTERNAL);
    assert_true(strlen(lf_last_error(e)) > 0);

    assert_int_equal(lf_has_result(e), 1);
    assert_int_equal(lf_get_result_views(e, &after), LF_OK);
    assert_memory_equal(&before, &after, sizeof before); /* the same planes, still valid */
    assert_true(scene_result_matches(e, &f->reference));

    /* The previous frame is still frame 1: pushing frame 0 again gives the reverse motion. */
    const lf_image_t l0 = scene_image(s->left0, W, H), r0 = scene_image(s->right0, W, H);
    assert_int_equal(lf_push_frame(e, 300000, &l0, &r0, NULL), LF_OK);
    lf_result_info_t info;
    lf_result_info_init(&info);
    assert_int_equal(lf_get_result_info(e, &info), LF_OK);
    assert_true(info.t0_us == 100000 && info.t1_us == 300000);
    scene_result_t r;
    assert_int_equal(scene_result_fetch(e, &r), LF_OK);
    const double acc = scene_result_accuracy(&r, -3, -1, 10);
    if (acc < 0.9) fail_msg("reverse motion: only %.1f %% within 1 px", 100 * acc);
    scene_result_free(&r);
    lf_destroy(e);
}

/* Degenerate sizes reach the core, which must answer with a status, never crash. */
static void test_tiny_and_odd_sizes(void **state) {
    fixture_t *f = (fixture_t *)*state;
    lf_estimator_t *e = new_estimator(&f->scene);
    static const int sizes[][2] = {{1, 1}, {2, 2}, {7, 3}, {3, 40}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; ++i) {
        const lf_image_t im = scene_image(f->scene.left0, sizes[i][0], sizes[i][1]);
        assert_int_equal(lf_reset(e), LF_OK);
        assert_int_equal(lf_push_frame(e, 0, &im, &im, NULL), LF_OK);
        const int32_t st = lf_push_frame(e, 1, &im, &im, NULL);
        if (st != LF_OK && st != LF_ERR_INVALID_ARGUMENT)
            fail_msg("%dx%d: status %d (%s)", sizes[i][0], sizes[i][1], (int)st, lf_last_error(e));
        if (st != LF_OK) assert_true(strlen(lf_last_error(e)) > 0);
    }
    lf_destroy(e);

    /* Odd sizes work like any other. */
    scene_t odd;
    assert_true(scene_make(&odd, 163, 67, 10, 3, 1, 11));
    e = new_estimator(&odd);
    if (scene_push_pair(e, &odd, 0, 1) != LF_OK) fail_msg("163x67: %s", lf_last_error(e));
    scene_result_t r;
    assert_int_equal(scene_result_fetch(e, &r), LF_OK);
    assert_int_equal(r.width, 163);
    assert_int_equal(r.height, 67);
    const double acc = scene_result_accuracy(&r, 3, 1, 10);
    if (acc < 0.95) fail_msg("163x67: only %.1f %% within 1 px", 100 * acc);
    scene_result_free(&r);
    lf_destroy(e);
    scene_free(&odd);
}

/* Padded input rows give the same result as packed ones. */
static void test_padded_strides(void **state) {
    fixture_t *f = (fixture_t *)*state;
    const scene_t *s = &f->scene;
    enum { STRIDE = W + 37 };
    static uint8_t pad[4][STRIDE * H];
    const uint8_t *src[4] = {s->left0, s->right0, s->left1, s->right1};
    for (int k = 0; k < 4; ++k) {
        memset(pad[k], 0xAB, sizeof pad[k]);
        for (int y = 0; y < H; ++y) memcpy(pad[k] + y * STRIDE, src[k] + y * W, W);
    }
    lf_image_t im[4];
    for (int k = 0; k < 4; ++k) {
        im[k] = scene_image(pad[k], W, H);
        im[k].stride_bytes = STRIDE;
    }
    float xyz[3 * 64];
    lf_lidar_t lidar = {LF_LIDAR_DISPARITY, scene_lidar(s, 16, xyz), xyz, 0};
    lf_estimator_t *e = new_estimator(s);
    assert_int_equal(lf_push_frame(e, 0, &im[0], &im[1], &lidar), LF_OK);
    assert_int_equal(lf_push_frame(e, 100000, &im[2], &im[3], &lidar), LF_OK);
    assert_true(scene_result_matches(e, &f->reference));
    lf_destroy(e);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reference_is_accurate),
        cmocka_unit_test(test_create_arguments),
        cmocka_unit_test(test_bad_images),
        cmocka_unit_test(test_bad_lidar),
        cmocka_unit_test(test_sequence_rules),
        cmocka_unit_test(test_pipeline_failure_keeps_state),
        cmocka_unit_test(test_tiny_and_odd_sizes),
        cmocka_unit_test(test_padded_strides),
    };
    return cmocka_run_group_tests_name("capi_inputs", tests, group_setup, group_teardown);
}
