/* SPDX-License-Identifier: MIT */
/* C ABI: lf_read_kitti_calibration — intrinsics, baseline and the composed Velodyne -> left
 * rectified transform from KITTI calibration text, and its errors; lf_read_calibration
 * (camera_info pair, KITTI with S_rect_02), the first lf_calibration_t layout (struct_size
 * LF_CALIBRATION_V1_SIZE) still read and written, the calibration's image size against the
 * pushed one (a warning once, or LF_ERR_SIZE_MISMATCH with "input.strict"), and a raw rig
 * rectified inside lf_push_frame. Compiled as C99 against the public header only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capi_scene.h"
#include "lidarflow/lidarflow.h"

static char g_cam[512], g_velo[512], g_bad[512], g_dir[512];

static void write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* `name` in the scratch folder. */
static const char *tmp_path(const char *name, char *path, size_t size) {
    snprintf(path, size, "%s/%s", g_dir, name);
    return path;
}

static int setup(void **state) {
    (void)state;
    const char *dir = getenv("LIDARFLOW_TEST_TMP");
    if (!dir || !*dir) dir = "/tmp";
    char mk[600];
    snprintf(mk, sizeof mk, "mkdir -p '%s'", dir);
    if (system(mk) != 0) return -1;
    snprintf(g_dir, sizeof g_dir, "%s", dir);
    snprintf(g_cam, sizeof g_cam, "%s/capi_calib_cam.txt", dir);
    snprintf(g_velo, sizeof g_velo, "%s/capi_calib_velo.txt", dir);
    snprintf(g_bad, sizeof g_bad, "%s/capi_calib_bad.txt", dir);
    /* Camera 2 sits 0.05 m left of camera 0 (P_rect_02(0,3) = fx * 0.05), camera 3 0.5 m right
     * of camera 2; R_rect_00 = I. */
    write_text(g_cam, "calib_time: 09-Jan-2012 13:57:47\n"
                      "R_rect_00: 1 0 0 0 1 0 0 0 1\n"
                      "P_rect_02: 700 0 600 35 0 710 180 0 0 0 1 0\n"
                      "P_rect_03: 700 0 600 -315 0 710 180 0 0 0 1 0\n");
    /* Velodyne (x forward, y left, z up) -> camera 0 (x right, y down, z forward), 0.3 m behind. */
    write_text(g_velo, "R: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 -0.3\n");
    write_text(g_bad, "P_rect_02: 700 0 600\n");
    return 0;
}

static void test_reads_camera_and_composes_lidar_transform(void **state) {
    (void)state;
    lf_calibration_t c;
    lf_calibration_init(&c);
    assert_int_equal(lf_read_kitti_calibration(g_cam, NULL, &c), LF_OK);
    assert_true(c.fx == 700 && c.fy == 710 && c.cx == 600 && c.cy == 180);
    assert_true(fabs(c.baseline - 0.5) < 1e-12);
    assert_int_equal(c.has_lidar_to_camera, 0);

    assert_int_equal(lf_read_kitti_calibration(g_cam, g_velo, &c), LF_OK);
    assert_int_equal(c.has_lidar_to_camera, 1);
    /* A point 10 m ahead of the Velodyne, 1 m to its left: camera 0 (-1, 0, 9.7), camera 2
     * 0.05 m further right -> (-0.95, 0, 9.7). */
    const double p[4] = {10, 1, 0, 1};
    double q[4] = {0, 0, 0, 0};
    for (int r = 0; r < 4; ++r)
        for (int k = 0; k < 4; ++k) q[r] += c.lidar_to_camera[4 * r + k] * p[k];
    assert_true(fabs(q[0] + 0.95) < 1e-12 && fabs(q[1]) < 1e-12 && fabs(q[2] - 9.7) < 1e-12 && q[3] == 1);
    /* The result is what lf_create accepts. */
    lf_estimator_t *e = NULL;
    assert_int_equal(lf_create(NULL, &c, &e), LF_OK);
    lf_destroy(e);
}

static void test_errors_leave_out_unchanged(void **state) {
    (void)state;
    lf_calibration_t c;
    lf_calibration_init(&c);
    c.fx = 123;
    assert_int_equal(lf_read_kitti_calibration("/nonexistent/calib.txt", NULL, &c), LF_ERR_IO);
    assert_non_null(strstr(lf_last_error(NULL), "/nonexistent/calib.txt"));
    assert_int_equal(lf_read_kitti_calibration(g_bad, NULL, &c), LF_ERR_FORMAT);
    assert_int_equal(lf_read_kitti_calibration(g_cam, g_bad, &c), LF_ERR_FORMAT);
    assert_int_equal(lf_read_kitti_calibration(g_cam, "/nonexistent/velo.txt", &c), LF_ERR_IO);
    assert_true(c.fx == 123 && c.has_lidar_to_camera == 0);
    assert_int_equal(lf_read_kitti_calibration(NULL, NULL, &c), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_last_error(NULL), "cam_to_cam_path is NULL"));
    assert_int_equal(lf_read_kitti_calibration(g_cam, NULL, NULL), LF_ERR_INVALID_ARGUMENT);
    c.struct_size = 8;
    assert_int_equal(lf_read_kitti_calibration(g_cam, NULL, &c), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_last_error(NULL), "lf_calibration_init"));
}

static void test_real_kitti_files(void **state) {
    (void)state;
    const char *root = getenv("LIDARFLOW_KITTI_DIR");
    if (!root || !*root) skip();
    char cam[600], velo[600];
    snprintf(cam, sizeof cam, "%s/calib_cam_to_cam/000002.txt", root);
    snprintf(velo, sizeof velo, "%s/calib_velo_to_cam/000002.txt", root);
    FILE *f = fopen(cam, "r");
    if (!f) skip();
    fclose(f);
    lf_calibration_t c;
    lf_calibration_init(&c);
    assert_int_equal(lf_read_kitti_calibration(cam, velo, &c), LF_OK);
    assert_true(fabs(c.fx - 721.5377) < 1e-4 && fabs(c.baseline - 0.532725) < 1e-5);
    /* The Velodyne origin sits ~0.27 m behind and ~0.08 m above camera 0; camera 2 is ~6 cm to
     * the left of camera 0, so the origin is ~6 cm to the right in camera 2's frame. */
    assert_true(fabs(c.lidar_to_camera[3] - 0.06) < 0.02);
    assert_true(fabs(c.lidar_to_camera[11] + 0.27) < 0.02);
}

static const char *camera_info(const char *distortion, double tx, char *buf, size_t size) {
    snprintf(buf, size,
             "image_width: 640\nimage_height: 480\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [700, 0, 320, 0, 700, "
             "240, 0, 0, 1]\ndistortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: "
             "%s\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
             "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [700, 0, 320, %g, 0, 700, 240, 0, 0, 0, 1, 0]\n",
             distortion, tx);
    return buf;
}

static void test_read_calibration(void **state) {
    (void)state;
    char text[1024], left[600], right[600], raw[600], spec[1300], kitti[600];
    write_text(tmp_path("capi_rig_left.yaml", left, sizeof left),
               camera_info("[0, 0, 0, 0, 0]", 0, text, sizeof text));
    write_text(tmp_path("capi_rig_right.yaml", right, sizeof right),
               camera_info("[0, 0, 0, 0, 0]", -350, text, sizeof text));
    write_text(tmp_path("capi_rig_raw.yaml", raw, sizeof raw),
               camera_info("[-0.2, 0.05, 0, 0, 0]", 0, text, sizeof text));
    snprintf(spec, sizeof spec, "%s,%s", left, right);
    lf_calibration_t c;
    lf_calibration_init(&c);
    assert_int_equal(lf_read_calibration(spec, NULL, &c), LF_OK);
    assert_true(c.fx == 700 && c.cx == 320 && c.cy == 240 && fabs(c.baseline - 0.5) < 1e-12);
    assert_int_equal(c.image_width, 640);
    assert_int_equal(c.image_height, 480);
    assert_int_equal(c.rectify, 0);

    /* A distorted left camera: rectify with the raw cameras. */
    snprintf(spec, sizeof spec, "%s,%s", raw, right);
    lf_calibration_init(&c);
    assert_int_equal(lf_read_calibration(spec, NULL, &c), LF_OK);
    assert_int_equal(c.rectify, 1);
    assert_true(c.raw_left.D[0] == -0.2 && c.raw_left.K[0] == 700 && c.raw_right.P[3] == -350);

    /* The first layout: the prefix is written, nothing after it; a raw rig does not fit. */
    lf_calibration_t whole; /* an old caller's struct followed by bytes that are not its */
    unsigned char *buf = (unsigned char *)&whole;
    memset(buf, 0xAB, sizeof whole);
    lf_calibration_t *v1 = &whole;
    v1->struct_size = LF_CALIBRATION_V1_SIZE;
    assert_int_equal(lf_read_calibration(spec, NULL, v1), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_last_error(NULL), "rectifying"));
    write_text(tmp_path("capi_rig_kitti.txt", kitti, sizeof kitti),
               "R_rect_00: 1 0 0 0 1 0 0 0 1\nP_rect_02: 700 0 320 0 0 700 240 0 0 0 1 0\n"
               "P_rect_03: 700 0 320 -350 0 700 240 0 0 0 1 0\nS_rect_02: 6.400000e+02 4.800000e+02\n");
    assert_int_equal(lf_read_kitti_calibration(kitti, NULL, v1), LF_OK);
    assert_int_equal(v1->struct_size, LF_CALIBRATION_V1_SIZE);
    assert_true(v1->fx == 700 && v1->baseline == 0.5);
    for (size_t i = LF_CALIBRATION_V1_SIZE; i < sizeof whole; ++i) assert_int_equal(buf[i], 0xAB);
    lf_calibration_init(&c);
    assert_int_equal(lf_read_kitti_calibration(kitti, NULL, &c), LF_OK);
    assert_int_equal(c.image_width, 640);
    assert_int_equal(c.image_height, 480);
    v1->struct_size = LF_CALIBRATION_V1_SIZE + 8; /* neither layout */
    assert_int_equal(lf_read_calibration(kitti, NULL, v1), LF_ERR_INVALID_ARGUMENT);

    /* Errors name the file. */
    assert_int_equal(lf_read_calibration(left, NULL, &c), LF_ERR_FORMAT);
    assert_non_null(strstr(lf_last_error(NULL), left));
    assert_int_equal(lf_read_calibration(NULL, NULL, &c), LF_ERR_INVALID_ARGUMENT);
}

static int g_warnings;
static char g_warning[512];

static void count_warnings(int32_t level, const char *message, void *user) {
    (void)user;
    if (level == LF_LOG_WARNING && strstr(message, "results use the calibration as it is")) {
        ++g_warnings;
        snprintf(g_warning, sizeof g_warning, "%s", message);
    }
}

static void test_image_size(void **state) {
    (void)state;
    scene_t s;
    assert_true(scene_make(&s, 96, 64, 6, 2, 1, 7));
    lf_calibration_t cal = scene_calibration(&s);
    cal.image_width = 100;
    cal.image_height = 64;
    lf_options_t *o = scene_options(1);
    assert_non_null(o);
    lf_estimator_t *e = NULL;
    assert_int_equal(lf_set_log_callback(count_warnings, LF_LOG_WARNING, NULL), LF_OK);
    g_warnings = 0;
    assert_int_equal(lf_create(o, &cal, &e), LF_OK);
    assert_int_equal(scene_push_pair(e, &s, 0, 0), LF_OK);
    assert_int_equal(scene_push_pair(e, &s, 1000000, 0), LF_OK);
    assert_int_equal(g_warnings, 1); /* four pushes, one warning */
    assert_non_null(strstr(g_warning, "96x64"));
    lf_destroy(e);

    assert_int_equal(lf_options_set_int(o, "input.strict", 1), LF_OK);
    assert_int_equal(lf_create(o, &cal, &e), LF_OK);
    assert_int_equal(scene_push_pair(e, &s, 0, 0), LF_ERR_SIZE_MISMATCH);
    assert_non_null(strstr(lf_last_error(e), "100x64"));
    lf_destroy(e);
    cal.image_width = 96; /* the right size passes, strict or not */
    assert_int_equal(lf_create(o, &cal, &e), LF_OK);
    assert_int_equal(scene_push_pair(e, &s, 0, 0), LF_OK);
    lf_destroy(e);
    assert_int_equal(lf_set_log_callback(NULL, LF_LOG_WARNING, NULL), LF_OK);

    /* The first layout: fields after it are not the caller's and are not read. */
    lf_calibration_t old;
    memset(&old, 0xAB, sizeof old);
    memcpy(&old, &cal, LF_CALIBRATION_V1_SIZE);
    old.struct_size = LF_CALIBRATION_V1_SIZE;
    assert_int_equal(lf_create(o, &old, &e), LF_OK);
    assert_int_equal(scene_push_pair(e, &s, 0, 0), LF_OK);
    lf_destroy(e);
    lf_options_destroy(o);
    scene_free(&s);
}

/* The raw right camera's principal point lies 3 px right of the rectified one, so its images
 * are the rectified ones shifted by 3 px: a scene at disparity 10 looks like disparity 7. The
 * estimator must undo that. */
static void test_rectified_inside(void **state) {
    (void)state;
    const int d = 10, shift = 3;
    scene_t raw;
    assert_true(scene_make(&raw, 160, 96, d - shift, 2, 1, 11));
    lf_calibration_t cal = scene_calibration(&raw);
    const double K[9] = {cal.fx, 0, cal.cx, 0, cal.fy, cal.cy, 0, 0, 1}, I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const double P[12] = {cal.fx, 0, cal.cx, 0, 0, cal.fy, cal.cy, 0, 0, 0, 1, 0};
    lf_raw_camera_t *cams[2] = {&cal.raw_left, &cal.raw_right};
    for (int k = 0; k < 2; ++k) {
        memcpy(cams[k]->K, K, sizeof K);
        memcpy(cams[k]->R, I, sizeof I);
        memcpy(cams[k]->P, P, sizeof P);
    }
    cal.raw_right.K[2] += shift;
    cal.raw_right.P[3] = -cal.fx * cal.baseline;
    lf_options_t *o = scene_options(1);
    lf_estimator_t *e = NULL;
    scene_result_t r;

    assert_int_equal(lf_create(o, &cal, &e), LF_OK); /* rectify = 0: the raw images as they are */
    assert_int_equal(scene_push_pair(e, &raw, 0, 0), LF_OK);
    assert_int_equal(scene_result_fetch(e, &r), LF_OK);
    const double as_is = scene_result_accuracy(&r, raw.tu, raw.tv, d);
    scene_result_free(&r);
    const char *first = NULL;
    assert_int_equal(lf_get_timing(e, 0, &first, NULL), LF_OK);
    assert_string_not_equal(first, "rectify");
    lf_result_info_t info;
    lf_result_info_init(&info);
    assert_int_equal(lf_get_result_info(e, &info), LF_OK);
    assert_int_equal(info.rectified, 0);
    lf_destroy(e);

    cal.rectify = 1;
    assert_int_equal(lf_create(o, &cal, &e), LF_OK);
    assert_int_equal(scene_push_pair(e, &raw, 0, 0), LF_OK);
    assert_int_equal(scene_result_fetch(e, &r), LF_OK);
    const double rectified = scene_result_accuracy(&r, raw.tu, raw.tv, d);
    scene_result_free(&r);
    double seconds = -1;
    assert_int_equal(lf_get_timing(e, 0, &first, &seconds), LF_OK);
    assert_string_equal(first, "rectify"); /* the result says its pair was rectified, and what it cost */
    assert_true(seconds >= 0 && seconds < 1);
    lf_result_info_init(&info);
    assert_int_equal(lf_get_result_info(e, &info), LF_OK);
    assert_int_equal(info.rectified, 1); /* the result info says its camera is the rectified one */
    lf_destroy(e);
    printf("pixels within 1 px of the true scene flow: %.1f %% as pushed, %.1f %% rectified inside\n", 100 * as_is,
           100 * rectified);
    assert_true(as_is < 0.05);
    assert_true(rectified > 0.8);

    /* fx ... baseline must be the raw cameras' rectified camera; reserved must be 0. */
    cal.fx += 1;
    assert_int_equal(lf_create(o, &cal, &e), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_last_error(NULL), "raw_left.P"));
    cal.fx -= 1;
    cal.reserved = 1;
    assert_int_equal(lf_create(o, &cal, &e), LF_ERR_INVALID_ARGUMENT);
    cal.reserved = 0;
    cal.raw_right.R[0] = 2; /* not a rotation */
    assert_int_equal(lf_create(o, &cal, &e), LF_ERR_INVALID_ARGUMENT);
    assert_null(e);
    lf_options_destroy(o);
    scene_free(&raw);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reads_camera_and_composes_lidar_transform),
        cmocka_unit_test(test_errors_leave_out_unchanged),
        cmocka_unit_test(test_real_kitti_files),
        cmocka_unit_test(test_read_calibration),
        cmocka_unit_test(test_image_size),
        cmocka_unit_test(test_rectified_inside),
    };
    return cmocka_run_group_tests_name("capi_calibration", tests, setup, NULL);
}
