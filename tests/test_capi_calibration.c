/* SPDX-License-Identifier: MIT */
/* C ABI: lf_read_kitti_calibration — intrinsics, baseline and the composed Velodyne -> left
 * rectified transform from KITTI calibration text, and its errors. Compiled as C99 against the
 * public header only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lidarflow/lidarflow.h"

static char g_cam[512], g_velo[512], g_bad[512];

static void write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static int setup(void **state) {
    (void)state;
    const char *dir = getenv("LIDARFLOW_TEST_TMP");
    if (!dir || !*dir) dir = "/tmp";
    char mk[600];
    snprintf(mk, sizeof mk, "mkdir -p '%s'", dir);
    if (system(mk) != 0) return -1;
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

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reads_camera_and_composes_lidar_transform),
        cmocka_unit_test(test_errors_leave_out_unchanged),
        cmocka_unit_test(test_real_kitti_files),
    };
    return cmocka_run_group_tests_name("capi_calibration", tests, setup, NULL);
}
