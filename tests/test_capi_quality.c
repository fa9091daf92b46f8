/* SPDX-License-Identifier: MIT */
/* C ABI: the input quality of a result (lf_get_quality, lf_quality_name). The synthetic scene is
 * ok; the same scene with the rig's usual mistakes, made here at run time, is flagged: left and
 * right swapped, the right image rotated and shifted (not rectified), black t1 images, a frozen
 * camera (t1 = t0), and LiDAR disparities that do not fit the images. Compiled as C99 against
 * the public header only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "capi_scene.h"

#define W 320
#define H 96
#define D 10

typedef struct frame_t {
    const uint8_t *left, *right;
} frame_t;

/* Pushes two frames with grid LiDAR of disparity D + lidar_error at both; returns the status. */
static int32_t push_two(lf_estimator_t *e, frame_t f0, frame_t f1, const scene_t *s, float lidar_error) {
    float xyz[3 * (W / 16) * (H / 16)];
    lf_lidar_t lidar;
    memset(&lidar, 0, sizeof lidar);
    lidar.kind = LF_LIDAR_DISPARITY;
    lidar.count = scene_lidar(s, 16, xyz);
    for (uint32_t i = 0; i < lidar.count; ++i) xyz[3 * i + 2] += lidar_error;
    lidar.data = xyz;
    const lf_image_t l0 = scene_image(f0.left, W, H), r0 = scene_image(f0.right, W, H);
    const lf_image_t l1 = scene_image(f1.left, W, H), r1 = scene_image(f1.right, W, H);
    int32_t st = lf_push_frame(e, 0, &l0, &r0, &lidar);
    if (st == LF_OK) st = lf_push_frame(e, 100000, &l1, &r1, &lidar);
    return st;
}

static lf_estimator_t *new_estimator(const scene_t *s) {
    lf_options_t *o = scene_options(2);
    lf_calibration_t c = scene_calibration(s);
    lf_estimator_t *e = NULL;
    if (!o || lf_options_set_string(o, "preset", "realtime") != LF_OK || lf_create(o, &c, &e) != LF_OK) e = NULL;
    lf_options_destroy(o);
    return e;
}

/* The flags of the pair's result (the push must succeed). */
static uint32_t quality_of(frame_t f0, frame_t f1, const scene_t *s, float lidar_error, const char **reason) {
    lf_estimator_t *e = new_estimator(s);
    assert_non_null(e);
    const int32_t st = push_two(e, f0, f1, s, lidar_error);
    if (st != LF_OK) fail_msg("push: %s", lf_last_error(e));
    uint32_t flags = 0xffffffffu;
    static char text[512];
    const char *r = NULL;
    assert_int_equal(lf_get_quality(e, &flags, &r), LF_OK);
    assert_non_null(r);
    snprintf(text, sizeof text, "%s", r);
    if (reason) *reason = text;
    lf_destroy(e);
    return flags;
}

/* The flags of the pair's result; when the push fails (an estimator that finds nothing to match
 * in wrong inputs), the flag named in its message ("(input quality: NAME ...)") instead, and
 * *reason is that message. */
static uint32_t quality_or_error(frame_t f0, frame_t f1, const scene_t *s, const char **reason) {
    lf_estimator_t *e = new_estimator(s);
    assert_non_null(e);
    static char text[512];
    uint32_t flags = 0;
    if (push_two(e, f0, f1, s, 0) == LF_OK) {
        const char *r = NULL;
        assert_int_equal(lf_get_quality(e, &flags, &r), LF_OK);
        snprintf(text, sizeof text, "%s", r);
    } else {
        snprintf(text, sizeof text, "%s", lf_last_error(e));
        const char *q = strstr(text, "(input quality: ");
        if (!q) fail_msg("push failed without naming the input quality: %s", text);
        for (uint32_t bit = 1; bit <= LF_QUALITY_LIDAR_DISAGREES; bit <<= 1)
            if (strstr(q, lf_quality_name(bit))) flags |= bit;
    }
    *reason = text;
    lf_destroy(e);
    return flags;
}

static scene_t scene;

static void test_names(void **state) {
    (void)state;
    assert_string_equal(lf_quality_name(0), "ok");
    assert_string_equal(lf_quality_name(LF_QUALITY_LEFT_RIGHT_SWAPPED), "left_right_swapped");
    assert_string_equal(lf_quality_name(LF_QUALITY_NOT_RECTIFIED), "not_rectified");
    assert_string_equal(lf_quality_name(LF_QUALITY_CALIBRATION_SIZE_MISMATCH), "calibration_size_mismatch");
    assert_string_equal(lf_quality_name(LF_QUALITY_BLANK_FRAME), "blank_frame");
    assert_string_equal(lf_quality_name(LF_QUALITY_LIDAR_DISAGREES), "lidar_disagrees");
    assert_string_equal(lf_quality_name(3), "unknown");
    assert_string_equal(lf_quality_name(1u << 31), "unknown");
}

static void test_not_ready_and_null(void **state) {
    (void)state;
    lf_estimator_t *e = new_estimator(&scene);
    assert_non_null(e);
    uint32_t flags = 7;
    assert_int_equal(lf_get_quality(e, &flags, NULL), LF_ERR_NOT_READY);
    assert_int_equal(flags, 7); /* unchanged on error */
    assert_int_equal(lf_get_quality(NULL, &flags, NULL), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(push_two(e, (frame_t){scene.left0, scene.right0}, (frame_t){scene.left1, scene.right1}, &scene, 0),
                     LF_OK);
    assert_int_equal(lf_get_quality(e, NULL, NULL), LF_OK); /* both outputs optional */
    lf_destroy(e);
}

static void test_correct_rig_is_ok(void **state) {
    (void)state;
    const char *why = NULL;
    const uint32_t f =
        quality_of((frame_t){scene.left0, scene.right0}, (frame_t){scene.left1, scene.right1}, &scene, 0, &why);
    if (f != 0) fail_msg("flags %u: %s", f, why);
    assert_string_equal(why, "");
}

static void test_swapped(void **state) {
    (void)state;
    const char *why = NULL;
    const uint32_t f =
        quality_or_error((frame_t){scene.right0, scene.left0}, (frame_t){scene.right1, scene.left1}, &scene, &why);
    if (!(f & LF_QUALITY_LEFT_RIGHT_SWAPPED)) fail_msg("flags %u: %s", f, why);
    assert_non_null(strstr(why, "negative disparity"));
}

/* dst = src rotated by `deg` about the centre and moved down by `shift` px (nearest pixel). */
static void rotate_shift(const uint8_t *src, uint8_t *dst, double deg, double shift) {
    const double a = deg * 3.14159265358979 / 180, c = cos(a), s = sin(a);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const double dx = x - W / 2.0, dy = y - shift - H / 2.0;
            int sx = (int)lround(c * dx + s * dy + W / 2.0), sy = (int)lround(-s * dx + c * dy + H / 2.0);
            sx = sx < 0 ? 0 : sx >= W ? W - 1 : sx;
            sy = sy < 0 ? 0 : sy >= H ? H - 1 : sy;
            dst[y * W + x] = src[sy * W + sx];
        }
}

static void test_not_rectified(void **state) {
    (void)state;
    static uint8_t r0[W * H], r1[W * H];
    rotate_shift(scene.right0, r0, 1.5, 6);
    rotate_shift(scene.right1, r1, 1.5, 6);
    const char *why = NULL;
    const uint32_t f = quality_of((frame_t){scene.left0, r0}, (frame_t){scene.left1, r1}, &scene, 0, &why);
    assert_true(f & LF_QUALITY_NOT_RECTIFIED);
    assert_false(f & LF_QUALITY_LEFT_RIGHT_SWAPPED);
    assert_non_null(strstr(why, "vertically"));
}

static void test_black_t1(void **state) {
    (void)state;
    static uint8_t black[W * H];
    lf_estimator_t *e = new_estimator(&scene);
    assert_non_null(e);
    const int32_t st = push_two(e, (frame_t){scene.left0, scene.right0}, (frame_t){black, black}, &scene, 0);
    if (st != LF_OK) fail_msg("push: %s", lf_last_error(e));
    uint32_t flags = 0;
    const char *why = NULL;
    assert_int_equal(lf_get_quality(e, &flags, &why), LF_OK);
    assert_int_equal(flags, LF_QUALITY_BLANK_FRAME);
    assert_non_null(strstr(why, "left1 is black"));
    lf_destroy(e);
}

static void test_frozen(void **state) {
    (void)state;
    const char *why = NULL;
    const uint32_t f =
        quality_of((frame_t){scene.left0, scene.right0}, (frame_t){scene.left0, scene.right0}, &scene, 0, &why);
    assert_int_equal(f, LF_QUALITY_BLANK_FRAME);
    assert_non_null(strstr(why, "frozen"));
}

static void test_lidar_disagrees(void **state) {
    (void)state;
    const char *why = NULL;
    /* 1 px off stays within what a calibrated rig leaves; 6 px does not. */
    uint32_t f = quality_of((frame_t){scene.left0, scene.right0}, (frame_t){scene.left1, scene.right1}, &scene, 1, &why);
    if (f != 0) fail_msg("flags %u: %s", f, why);
    f = quality_of((frame_t){scene.left0, scene.right0}, (frame_t){scene.left1, scene.right1}, &scene, 6, &why);
    assert_int_equal(f, LF_QUALITY_LIDAR_DISAGREES);
    assert_non_null(strstr(why, "LiDAR-to-camera"));
}

int main(void) {
    if (!scene_make(&scene, W, H, D, 3, 1, 11)) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names),           cmocka_unit_test(test_not_ready_and_null),
        cmocka_unit_test(test_correct_rig_is_ok), cmocka_unit_test(test_swapped),
        cmocka_unit_test(test_not_rectified),   cmocka_unit_test(test_black_t1),
        cmocka_unit_test(test_frozen),          cmocka_unit_test(test_lidar_disagrees),
    };
    const int failed = cmocka_run_group_tests(tests, NULL, NULL);
    scene_free(&scene);
    return failed;
}
