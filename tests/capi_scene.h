/* SPDX-License-Identifier: MIT */
/* Shared fixtures of the C ABI suites (C99, public header only): a synthetic stereo sequence
 * with exactly known scene flow, and small helpers. A fronto-parallel textured plane at
 * disparity d moves by (tu, tv) pixels between the frames, so every pixel's true scene flow
 * is (u, v, d0, d1) = (tu, tv, d, d). Integer shifts keep the images exact. */
#ifndef LIDARFLOW_TESTS_CAPI_SCENE_H
#define LIDARFLOW_TESTS_CAPI_SCENE_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "lidarflow/lidarflow.h"

typedef struct scene_t {
    int width, height;
    int d, tu, tv;
    uint8_t *left0, *right0, *left1, *right1; /* gray8, packed rows */
} scene_t;

/* Deterministic texture value of world pixel (x, y): random per 2x2 cell, box-smoothed so
 * that SIFT-like descriptors see gradients. */
static inline uint32_t scene_hash(uint32_t x, uint32_t y, uint32_t seed) {
    uint32_t h = x * 374761393u + y * 668265263u + seed * 2246822519u;
    h = (h ^ (h >> 13)) * 1274126177u;
    return h ^ (h >> 16);
}

static inline uint8_t scene_world(int x, int y, uint32_t seed) {
    int sum = 0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
            sum += (int)(scene_hash((uint32_t)(x + dx + 4096) / 2u, (uint32_t)(y + dy + 4096) / 2u, seed) & 255u);
    return (uint8_t)(sum / 9);
}

/* Fills s with a sequence of width x height gray images. Returns 0 on allocation failure. */
static inline int scene_make(scene_t *s, int width, int height, int d, int tu, int tv, uint32_t seed) {
    const size_t n = (size_t)width * (size_t)height;
    s->width = width;
    s->height = height;
    s->d = d;
    s->tu = tu;
    s->tv = tv;
    s->left0 = (uint8_t *)malloc(n);
    s->right0 = (uint8_t *)malloc(n);
    s->left1 = (uint8_t *)malloc(n);
    s->right1 = (uint8_t *)malloc(n);
    if (!s->left0 || !s->right0 || !s->left1 || !s->right1) return 0;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const size_t i = (size_t)y * (size_t)width + (size_t)x;
            /* A point at left pixel x appears at x - d in the right image. */
            s->left0[i] = scene_world(x, y, seed);
            s->right0[i] = scene_world(x + d, y, seed);
            s->left1[i] = scene_world(x - tu, y - tv, seed);
            s->right1[i] = scene_world(x + d - tu, y - tv, seed);
        }
    return 1;
}

static inline void scene_free(scene_t *s) {
    free(s->left0);
    free(s->right0);
    free(s->left1);
    free(s->right1);
    memset(s, 0, sizeof *s);
}

static inline lf_image_t scene_image(const uint8_t *data, int width, int height) {
    lf_image_t im;
    memset(&im, 0, sizeof im);
    im.data = data;
    im.width = (uint32_t)width;
    im.height = (uint32_t)height;
    im.stride_bytes = (uint64_t)width;
    im.format = LF_PIXEL_GRAY8;
    return im;
}

/* Sparse-disparity LiDAR entries (x, y, d) on a regular grid of `step` px: 3 floats each.
 * xyz must hold 3 * ((width / step) * (height / step)) floats; returns the count. */
static inline uint32_t scene_lidar(const scene_t *s, int step, float *xyz) {
    uint32_t n = 0;
    for (int y = step / 2; y < s->height; y += step)
        for (int x = step / 2; x < s->width; x += step) {
            xyz[3 * n + 0] = (float)x;
            xyz[3 * n + 1] = (float)y;
            xyz[3 * n + 2] = (float)s->d;
            ++n;
        }
    return n;
}

/* The calibration of the scene: fx * baseline = 50 px m, so disparity 10 is 5 m exactly. */
static inline lf_calibration_t scene_calibration(const scene_t *s) {
    lf_calibration_t c;
    lf_calibration_init(&c);
    c.fx = 100.0;
    c.fy = 100.0;
    c.cx = (double)(s->width / 2);
    c.cy = (double)(s->height / 2);
    c.baseline = 0.5;
    return c;
}

/* Options for quick runs on the small scene: the pyramid gets a second level on 64-px-high
 * images (the default coarsest height of 40 px leaves one level there, where PatchMatch does
 * not converge from a 400 px random search). Everything else stays at the defaults. */
static inline lf_options_t *scene_options(int threads) {
    lf_options_t *o = NULL;
    if (lf_options_create(&o) != LF_OK) return NULL;
    if (lf_options_set_int(o, "matching.min_coarsest_height", 16) != LF_OK ||
        lf_options_set_int(o, "threads", threads) != LF_OK ||
        /* the count asked for, however busy the machine: suites compare thread counts */
        lf_options_set_int(o, "adaptive_threads", 0) != LF_OK) {
        lf_options_destroy(o);
        return NULL;
    }
    return o;
}

/* A result copied out of an estimator into packed planes. */
typedef struct scene_result_t {
    uint32_t width, height;
    float *u, *v, *d0, *d1, *confidence;
    uint8_t *valid;
} scene_result_t;

static inline void scene_result_free(scene_result_t *r) {
    free(r->u);
    free(r->v);
    free(r->d0);
    free(r->d1);
    free(r->confidence);
    free(r->valid);
    memset(r, 0, sizeof *r);
}

/* Copies the estimator's result with lf_get_result; returns its status. */
static inline int32_t scene_result_fetch(lf_estimator_t *e, scene_result_t *r) {
    lf_result_info_t info;
    lf_result_info_init(&info);
    memset(r, 0, sizeof *r);
    int32_t st = lf_get_result_info(e, &info);
    if (st != LF_OK) return st;
    const size_t n = (size_t)info.width * info.height;
    r->width = info.width;
    r->height = info.height;
    r->u = (float *)malloc(n * sizeof(float));
    r->v = (float *)malloc(n * sizeof(float));
    r->d0 = (float *)malloc(n * sizeof(float));
    r->d1 = (float *)malloc(n * sizeof(float));
    r->confidence = (float *)malloc(n * sizeof(float));
    r->valid = (uint8_t *)malloc(n);
    if (!r->u || !r->v || !r->d0 || !r->d1 || !r->confidence || !r->valid) return LF_ERR_OUT_OF_MEMORY;
    lf_result_buffers_t b;
    lf_result_buffers_init(&b);
    b.width = info.width;
    b.height = info.height;
    b.u.data = r->u;
    b.v.data = r->v;
    b.d0.data = r->d0;
    b.d1.data = r->d1;
    b.confidence.data = r->confidence;
    b.u.stride_bytes = b.v.stride_bytes = b.d0.stride_bytes = b.d1.stride_bytes = b.confidence.stride_bytes =
        info.width * sizeof(float);
    b.valid.data = r->valid;
    b.valid.stride_bytes = info.width;
    return lf_get_result(e, &b);
}

/* 1 when both results are bit-identical. */
static inline int scene_result_equal(const scene_result_t *a, const scene_result_t *b) {
    if (a->width != b->width || a->height != b->height) return 0;
    const size_t n = (size_t)a->width * a->height;
    return memcmp(a->u, b->u, n * 4) == 0 && memcmp(a->v, b->v, n * 4) == 0 && memcmp(a->d0, b->d0, n * 4) == 0 &&
           memcmp(a->d1, b->d1, n * 4) == 0 && memcmp(a->confidence, b->confidence, n * 4) == 0 &&
           memcmp(a->valid, b->valid, n) == 0;
}

/* Whether the estimator's current result is bit-identical to `ref`; 0 when it cannot be fetched. */
static inline int scene_result_matches(lf_estimator_t *e, const scene_result_t *ref) {
    scene_result_t r;
    const int same = scene_result_fetch(e, &r) == LF_OK && scene_result_equal(&r, ref);
    scene_result_free(&r);
    return same;
}

/* Share of valid pixels whose (u, v, d0, d1) are within 1 px of the truth (tu, tv, d, d). */
static inline double scene_result_accuracy(const scene_result_t *r, int tu, int tv, int d) {
    size_t good = 0;
    const size_t n = (size_t)r->width * r->height;
    for (size_t i = 0; i < n; ++i) {
        if (!r->valid[i]) continue;
        const float eu = r->u[i] - (float)tu, ev = r->v[i] - (float)tv;
        const float e0 = r->d0[i] - (float)d, e1 = r->d1[i] - (float)d;
        good += eu > -1 && eu < 1 && ev > -1 && ev < 1 && e0 > -1 && e0 < 1 && e1 > -1 && e1 < 1;
    }
    return (double)good / (double)n;
}

/* Pushes the scene's two frames (timestamps t, t + 100000) with sparse-disparity LiDAR on a
 * 16 px grid (NULL lidar when with_lidar is 0). Returns the first failing status. */
static inline int32_t scene_push_pair(lf_estimator_t *e, const scene_t *s, int64_t t, int with_lidar) {
    float *xyz = (float *)malloc(sizeof(float) * 3 * (size_t)(s->width / 16 + 1) * (size_t)(s->height / 16 + 1));
    if (!xyz) return LF_ERR_OUT_OF_MEMORY;
    lf_lidar_t lidar;
    memset(&lidar, 0, sizeof lidar);
    lidar.kind = LF_LIDAR_DISPARITY;
    lidar.count = scene_lidar(s, 16, xyz);
    lidar.data = xyz;
    const lf_image_t l0 = scene_image(s->left0, s->width, s->height), r0 = scene_image(s->right0, s->width, s->height);
    const lf_image_t l1 = scene_image(s->left1, s->width, s->height), r1 = scene_image(s->right1, s->width, s->height);
    int32_t st = lf_push_frame(e, t, &l0, &r0, with_lidar ? &lidar : NULL);
    if (st == LF_OK) st = lf_push_frame(e, t + 100000, &l1, &r1, with_lidar ? &lidar : NULL);
    free(xyz);
    return st;
}

#endif
