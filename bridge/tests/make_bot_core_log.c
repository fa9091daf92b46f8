// SPDX-License-Identifier: MIT
// An LCM log as bot_core-typed drivers would record it, made WITHOUT any lidarflow code: the
// messages are encoded by lcm-gen's generated C encoders for bot_core.images_t / pointcloud_t and
// written by liblcm's own lcm_eventlog writer (what lcm-logger uses). The bridge's --replay
// and its bot_core decoders are then tested against input they did not produce themselves.
//
//   make_bot_core_log OUT.log CALIB_DIR FRAMES
//
// Scene (rendered per pixel, so every frame is consistent): a textured background plane the
// camera drives towards and a textured box moving to the right in front of it. Camera 320x96,
// fx = fy = 400, cx = 160, cy = 48, baseline 0.5 m (written as CALIB_DIR/calib_cam_to_cam.txt).
// Channels, as a driver would name them:
//   STEREO_CAMERA    images_t: entries RIGHT, LEFT (RGB, rows padded to a larger row_stride,
//                    with a metadata entry) and a DISPARITY image the bridge must ignore
//   VELODYNE_POINTS  pointcloud_t in the LiDAR frame (x forward, y left, z up), with an
//                    intensity channel, 5 ms after its frame, including points behind the camera
//   POSE             bytes of some other type (the bridge counts and leaves it out)
// Prints the LiDAR -> camera transform (16 numbers) for --lidar-to-camera.
#include <lcm/eventlog.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bot_core_images_t.h"
#include "bot_core_pointcloud_t.h"

enum { W = 320, H = 96, STRIDE = W * 3 + 16 };
static const double FX = 400, CX = 160, CY = 48, BASELINE = 0.5;
// LiDAR -> left camera: camera x = -lidar y, camera y = -lidar z, camera z = lidar x, plus an offset.
static const double T[16] = {0, -1, 0, 0.06, 0, 0, -1, -0.08, 1, 0, 0, -0.27, 0, 0, 0, 1};

static double hash01(int32_t x, int32_t y, uint32_t seed) {
    uint32_t h = (uint32_t)x * 374761393u + (uint32_t)y * 668265263u + seed * 2246822519u;
    h = (h ^ (h >> 13)) * 1274126177u;
    return (double)(h ^ (h >> 16)) / 4294967296.0;
}

// Bilinear value noise, one cell per unit.
static double noise(double x, double y, uint32_t seed) {
    const double fx = x - (double)(int32_t)(x < 0 ? x - 1 : x), fy = y - (double)(int32_t)(y < 0 ? y - 1 : y);
    const int32_t ix = (int32_t)(x - fx), iy = (int32_t)(y - fy);
    const double a = hash01(ix, iy, seed), b = hash01(ix + 1, iy, seed), c = hash01(ix, iy + 1, seed),
                 d = hash01(ix + 1, iy + 1, seed);
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy;
}

// Texture at surface coordinates (x, y) [m].
static double texture(double x, double y, uint32_t seed) {
    return 0.5 * noise(3 * x, 3 * y, seed) + 0.3 * noise(8 * x, 8 * y, seed + 7) + 0.2 * noise(16 * x, 16 * y, seed + 13);
}

// What camera pixel (u, v) of a camera centred at x = ox sees in frame k: the 3-D point in
// the left camera frame (*X, *Y, *Z) and the texture coordinates on its surface.
static void trace(int k, double ox, double u, double v, double *X, double *Y, double *Z, double *tx, double *ty,
                  uint32_t *seed) {
    const double box_z = 8, box_x0 = -1.5 + 0.3 * k, box_x1 = 1.0 + 0.3 * k, box_y0 = -0.6, box_y1 = 2.0;
    double z = box_z, x = ox + (u - CX) * z / FX, y = (v - CY) * z / FX;
    if (x >= box_x0 && x <= box_x1 && y >= box_y0 && y <= box_y1) {
        *tx = x - 0.3 * k;  // the texture moves with the box
        *ty = y;
        *seed = 1000;
    } else {
        z = 20 - 0.4 * k;   // the camera drives 0.4 m per frame towards the static background
        x = ox + (u - CX) * z / FX;
        y = (v - CY) * z / FX;
        *tx = x;
        *ty = y;
        *seed = 2000;
    }
    *X = x;
    *Y = y;
    *Z = z;
}

static void render(int k, double ox, uint8_t *rgb) {
    memset(rgb, 0xEE, (size_t)STRIDE * H);  // row padding: never read as pixels
    for (int v = 0; v < H; ++v)
        for (int u = 0; u < W; ++u) {
            double X, Y, Z, tx, ty;
            uint32_t seed;
            trace(k, ox, u, v, &X, &Y, &Z, &tx, &ty, &seed);
            const double r = texture(tx, ty, seed), g = texture(tx, ty, seed + 1);
            uint8_t *p = rgb + (size_t)v * STRIDE + (size_t)u * 3;
            p[0] = (uint8_t)(30 + 200 * r);
            p[1] = (uint8_t)(30 + 100 * (r + g));
            p[2] = (uint8_t)(30 + 200 * g);
        }
}

static int write_event(lcm_eventlog_t *log, const char *channel, int64_t timestamp, void *data, int32_t size) {
    lcm_eventlog_event_t e;
    memset(&e, 0, sizeof e);
    e.timestamp = timestamp;
    e.channellen = (int32_t)strlen(channel);
    e.datalen = size;
    e.channel = (char *)channel;
    e.data = data;
    return lcm_eventlog_write_event(log, &e);
}

static int write_images(lcm_eventlog_t *log, int k, int64_t utime) {
    static uint8_t left[STRIDE * H], right[STRIDE * H], disparity[W * H];
    render(k, 0, left);
    render(k, BASELINE, right);
    memset(disparity, 7, sizeof disparity);
    char key[] = "exposure_us";
    uint8_t value[4] = {0, 0, 0x27, 0x10};
    bot_core_image_metadata_t meta = {key, 4, value};
    bot_core_image_t ims[3];
    memset(ims, 0, sizeof ims);
    uint8_t *data[3] = {right, left, disparity};
    for (int i = 0; i < 3; ++i) {
        ims[i].utime = utime;
        ims[i].width = W;
        ims[i].height = H;
        ims[i].row_stride = i < 2 ? STRIDE : W;
        ims[i].pixelformat = i < 2 ? BOT_CORE_IMAGE_T_PIXEL_FORMAT_RGB : BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY;
        ims[i].size = i < 2 ? STRIDE * H : W * H;
        ims[i].data = data[i];
        ims[i].nmetadata = i < 2 ? 1 : 0;
        ims[i].metadata = &meta;
    }
    int16_t roles[3] = {BOT_CORE_IMAGES_T_RIGHT, BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_DISPARITY};
    bot_core_images_t msg = {utime, 3, roles, ims};
    const int size = bot_core_images_t_encoded_size(&msg);
    uint8_t *buf = malloc((size_t)size);
    int rc = !buf || bot_core_images_t_encode(buf, 0, size, &msg) != size ||
             write_event(log, "STEREO_CAMERA", utime, buf, size) != 0;
    free(buf);
    return rc;
}

static int write_sweep(lcm_eventlog_t *log, int k, int64_t utime) {
    enum { MAX = 4096 };
    static float points[MAX][3], intensity[MAX];
    int n = 0;
    // Scan lines over the camera's view: the surface point behind every 3rd pixel of every 6th row.
    for (int v = 3; v < H && n < MAX; v += 6)
        for (int u = 1; u < W && n < MAX; u += 3) {
            double X, Y, Z, tx, ty;
            uint32_t seed;
            trace(k, 0, u + 0.25, v + 0.25, &X, &Y, &Z, &tx, &ty, &seed);
            // Camera -> LiDAR: p_l = R^T (p_c - t).
            const double dx = X - T[3], dy = Y - T[7], dz = Z - T[11];
            points[n][0] = (float)dz;
            points[n][1] = (float)-dx;
            points[n][2] = (float)-dy;
            intensity[n] = (float)texture(tx, ty, seed);
            ++n;
        }
    // A real sweep covers 360 degrees: points behind the camera, which the estimator drops.
    for (int i = 0; i < 64 && n < MAX; ++i, ++n) {
        points[n][0] = -6.0f - 0.1f * (float)i;
        points[n][1] = 3.0f - 0.1f * (float)i;
        points[n][2] = -1.5f;
        intensity[n] = 0.5f;
    }
    float *point_rows[MAX], *channel_rows[1] = {intensity};
    for (int i = 0; i < n; ++i) point_rows[i] = points[i];
    char frame_id[] = "velodyne", name[] = "intensity";
    char *names[1] = {name};
    bot_core_pointcloud_t msg = {utime, k, frame_id, n, point_rows, 1, names, channel_rows};
    const int size = bot_core_pointcloud_t_encoded_size(&msg);
    uint8_t *buf = malloc((size_t)size);
    int rc = !buf || bot_core_pointcloud_t_encode(buf, 0, size, &msg) != size ||
             write_event(log, "VELODYNE_POINTS", utime, buf, size) != 0;
    free(buf);
    return rc;
}

int main(int argc, char **argv) {
    if (argc != 4 || atoi(argv[3]) < 2) {
        fprintf(stderr, "usage: make_bot_core_log OUT.log CALIB_DIR FRAMES(>=2)\n");
        return 2;
    }
    const int frames = atoi(argv[3]);
    char path[4096];
    snprintf(path, sizeof path, "%s/calib_cam_to_cam.txt", argv[2]);
    FILE *calib = fopen(path, "w");
    if (!calib) {
        perror(path);
        return 1;
    }
    fprintf(calib, "R_rect_00: 1 0 0 0 1 0 0 0 1\n"); /* as in every KITTI file, which lidarflow's reader needs */
    fprintf(calib, "P_rect_02: %g 0 %g 0 0 %g %g 0 0 0 1 0\n", FX, CX, FX, CY);
    fprintf(calib, "P_rect_03: %g 0 %g %g 0 %g %g 0 0 0 1 0\n", FX, CX, -FX * BASELINE, FX, CY);
    fclose(calib);
    lcm_eventlog_t *log = lcm_eventlog_create(argv[1], "w");
    if (!log) {
        perror(argv[1]);
        return 1;
    }
    int rc = 0;
    for (int k = 0; k < frames && rc == 0; ++k) {
        const int64_t utime = 1500000000000000LL + 100000LL * k;  // 10 Hz
        uint8_t pose[40];
        memset(pose, k, sizeof pose);
        rc |= write_images(log, k, utime);
        rc |= write_event(log, "POSE", utime + 1000, pose, (int32_t)sizeof pose);
        rc |= write_sweep(log, k, utime + 5000);
    }
    lcm_eventlog_destroy(log);
    if (rc) {
        fprintf(stderr, "make_bot_core_log: encoding or writing failed\n");
        return 1;
    }
    for (int i = 0; i < 16; ++i) printf("%g%s", T[i], i < 15 ? " " : "\n");
    return 0;
}
