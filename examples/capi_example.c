/* SPDX-License-Identifier: MIT */
/* lidarflow from C: two stereo frames of a textured wall 5 m ahead that slides 4 px to the
 * right, plus a few LiDAR returns, give a dense scene flow; the example prints its mean.
 * Build against an installed lidarflow:
 *     cc -std=c99 capi_example.c $(pkg-config --cflags --libs lidarflow) -o capi_example */
#include <stdio.h>
#include <stdlib.h>

#include <lidarflow/lidarflow.h>

enum { W = 320, H = 96, DISP = 12, MOVE = 4 };

/* Texture of the wall at wall coordinate (x, y). */
static uint8_t wall(int x, int y) {
    uint32_t h = (uint32_t)(x / 2 + 1000) * 374761393u + (uint32_t)(y / 2 + 1000) * 668265263u;
    h = (h ^ (h >> 13)) * 1274126177u;
    return (uint8_t)(h >> 24);
}

/* Left/right images of the wall shifted by `move` px: a point at left x is at x - DISP right. */
static void render(uint8_t *left, uint8_t *right, int move) {
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            left[y * W + x] = wall(x - move, y);
            right[y * W + x] = wall(x + DISP - move, y);
        }
}

#define CHECK(call, est)                                                                       \
    do {                                                                                       \
        if ((call) != LF_OK) {                                                                 \
            fprintf(stderr, "%s failed: %s\n", #call, lf_last_error(est));                     \
            return 1;                                                                          \
        }                                                                                      \
    } while (0)

int main(void) {
    static uint8_t left[W * H], right[W * H];
    lf_options_t *opt = NULL;
    CHECK(lf_options_create(&opt), NULL);
    CHECK(lf_options_set_int(opt, "threads", 2), NULL);

    lf_calibration_t cal;
    lf_calibration_init(&cal);
    cal.fx = cal.fy = 300.0;
    cal.cx = W / 2.0;
    cal.cy = H / 2.0;
    cal.baseline = 0.2; /* disparity 12 px = 300 * 0.2 / 5 m */

    lf_estimator_t *est = NULL;
    CHECK(lf_create(opt, &cal, &est), NULL);
    lf_options_destroy(opt); /* the estimator keeps its own copy */

    /* LiDAR returns as sparse disparities (x, y, d); 3-D points work too (LF_LIDAR_POINTS_*). */
    float lidar_xyd[3 * 8];
    for (int i = 0; i < 8; ++i) {
        lidar_xyd[3 * i] = (float)(20 + 40 * i);
        lidar_xyd[3 * i + 1] = (float)(H / 2);
        lidar_xyd[3 * i + 2] = (float)DISP;
    }
    const lf_lidar_t lidar = {LF_LIDAR_DISPARITY, 8, lidar_xyd, 0};
    const lf_image_t l = {left, W, H, W, LF_PIXEL_GRAY8}, r = {right, W, H, W, LF_PIXEL_GRAY8};

    for (int frame = 0; frame < 2; ++frame) {
        render(left, right, frame * MOVE); /* the library copies the images: buffers are reusable */
        CHECK(lf_push_frame(est, frame * 100000, &l, &r, &lidar), est);
    }
    if (!lf_has_result(est)) return 1;

    /* Copy u and d0 into our own buffers (lf_get_result_views borrows them instead). */
    static float u[W * H], d0[W * H];
    lf_result_buffers_t out;
    lf_result_buffers_init(&out);
    out.width = W;
    out.height = H;
    out.u.data = u;
    out.u.stride_bytes = W * sizeof(float);
    out.d0.data = d0;
    out.d0.stride_bytes = W * sizeof(float);
    CHECK(lf_get_result(est, &out), est);

    double su = 0, sd = 0;
    for (int i = 0; i < W * H; ++i) {
        su += u[i];
        sd += d0[i];
    }
    lf_result_info_t info;
    lf_result_info_init(&info);
    CHECK(lf_get_result_info(est, &info), est);
    printf("lidarflow %s: mean flow u %.2f px (truth %d), mean disparity %.2f px (truth %d), %.2f s\n",
           lf_version_string(), su / (W * H), MOVE, sd / (W * H), DISP, info.total_seconds);
    lf_destroy(est);
    return 0;
}
