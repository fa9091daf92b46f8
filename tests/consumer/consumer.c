/* SPDX-License-Identifier: MIT */
/* A downstream C99 program that sees only the installed header and library: it runs the full
 * pipeline on one frame pair given as plain files and writes the raw result.
 *   consumer IN OUT
 * IN:  left0.ppm right0.ppm left1.ppm right1.ppm (binary P6 RGB or P5 gray, maxval 255),
 *      lidar0.txt lidar1.txt ("x y d" per line: sparse disparities), calib.txt ("fx fy cx cy B")
 * OUT: size.txt ("W H"), u.f32 v.f32 d0.f32 d1.f32 (float32 planes), valid.u8 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lidarflow/lidarflow.h>

typedef struct pnm_t {
    uint8_t *data;
    uint32_t width, height, channels;
} pnm_t;

static int path_in(char *buf, size_t size, const char *dir, const char *name) {
    return snprintf(buf, size, "%s/%s", dir, name) < (int)size;
}

static int read_pnm(const char *dir, const char *name, pnm_t *img) {
    char path[4096], magic[3] = {0};
    unsigned w = 0, h = 0, maxval = 0;
    if (!path_in(path, sizeof path, dir, name)) return 0;
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    int ok = fscanf(f, "%2s %u %u %u", magic, &w, &h, &maxval) == 4 && fgetc(f) != EOF && maxval == 255 &&
             w > 0 && h > 0 && (strcmp(magic, "P5") == 0 || strcmp(magic, "P6") == 0);
    if (ok) {
        img->width = w;
        img->height = h;
        img->channels = magic[1] == '6' ? 3 : 1;
        const size_t n = (size_t)w * h * img->channels;
        img->data = (uint8_t *)malloc(n);
        ok = img->data && fread(img->data, 1, n, f) == n;
    }
    fclose(f);
    if (!ok) fprintf(stderr, "consumer: %s is not a binary 8-bit PNM\n", path);
    return ok;
}

static lf_image_t image_view(const pnm_t *p) {
    lf_image_t v;
    memset(&v, 0, sizeof v);
    v.data = p->data;
    v.width = p->width;
    v.height = p->height;
    v.stride_bytes = (uint64_t)p->width * p->channels;
    v.format = p->channels == 3 ? LF_PIXEL_RGB8 : LF_PIXEL_GRAY8;
    return v;
}

/* Reads "x y d" lines into a growing float array of (x, y, d) triples. */
static int read_lidar(const char *dir, const char *name, float **xyd, uint32_t *count) {
    char path[4096];
    if (!path_in(path, sizeof path, dir, name)) return 0;
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    size_t cap = 256, n = 0;
    float *a = (float *)malloc(cap * 3 * sizeof(float));
    float x, y, d;
    while (a && fscanf(f, "%f %f %f", &x, &y, &d) == 3) {
        if (n == cap) {
            float *b = (float *)realloc(a, 2 * cap * 3 * sizeof(float));
            if (!b) break;
            a = b;
            cap *= 2;
        }
        a[3 * n] = x;
        a[3 * n + 1] = y;
        a[3 * n + 2] = d;
        ++n;
    }
    const int ok = a && feof(f);
    fclose(f);
    *xyd = a;
    *count = (uint32_t)n;
    return ok;
}

static int write_file(const char *dir, const char *name, const void *data, size_t bytes) {
    char path[4096];
    if (!path_in(path, sizeof path, dir, name)) return 0;
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    const int ok = fwrite(data, 1, bytes, f) == bytes;
    return fclose(f) == 0 && ok;
}

#define CHECK(call, handle)                                                                   \
    do {                                                                                      \
        const int32_t st_ = (call);                                                           \
        if (st_ != LF_OK) {                                                                   \
            fprintf(stderr, "consumer: %s: %s: %s\n", #call, lf_status_string(st_),           \
                    lf_last_error(handle));                                                   \
            return 1;                                                                         \
        }                                                                                     \
    } while (0)

int main(int argc, char **argv) {
    if (lf_version_number() != LF_VERSION_NUMBER || lf_abi_major() != LF_ABI_MAJOR) {
        fprintf(stderr, "header %s / library %s mismatch\n", LF_VERSION_STRING, lf_version_string());
        return 1;
    }
    if (argc != 3) {
        fprintf(stderr, "usage: consumer IN OUT\n");
        return 2;
    }
    const char *in = argv[1], *out = argv[2];
    pnm_t img[4];
    static const char *names[4] = {"left0.ppm", "right0.ppm", "left1.ppm", "right1.ppm"};
    for (int k = 0; k < 4; ++k)
        if (!read_pnm(in, names[k], &img[k])) return 1;
    float *xyd[2];
    uint32_t count[2];
    if (!read_lidar(in, "lidar0.txt", &xyd[0], &count[0]) || !read_lidar(in, "lidar1.txt", &xyd[1], &count[1])) {
        fprintf(stderr, "consumer: cannot read the LiDAR lists\n");
        return 1;
    }
    lf_calibration_t cal;
    lf_calibration_init(&cal);
    char path[4096];
    FILE *f = path_in(path, sizeof path, in, "calib.txt") ? fopen(path, "r") : NULL;
    if (!f || fscanf(f, "%lf %lf %lf %lf %lf", &cal.fx, &cal.fy, &cal.cx, &cal.cy, &cal.baseline) != 5) {
        fprintf(stderr, "consumer: cannot read calib.txt\n");
        return 1;
    }
    fclose(f);

    /* The settings of `lidarflow run`: defaults, 2 threads. */
    lf_options_t *opt = NULL;
    CHECK(lf_options_create(&opt), NULL);
    CHECK(lf_options_set_int(opt, "threads", 2), NULL);
    lf_estimator_t *est = NULL;
    CHECK(lf_create(opt, &cal, &est), NULL);
    lf_options_destroy(opt);

    for (int t = 0; t < 2; ++t) {
        const lf_image_t left = image_view(&img[2 * t]), right = image_view(&img[2 * t + 1]);
        lf_lidar_t lidar;
        memset(&lidar, 0, sizeof lidar);
        lidar.kind = LF_LIDAR_DISPARITY;
        lidar.count = count[t];
        lidar.data = xyd[t];
        CHECK(lf_push_frame(est, (int64_t)t * 100000, &left, &right, &lidar), est);
    }

    lf_result_info_t info;
    lf_result_info_init(&info);
    CHECK(lf_get_result_info(est, &info), est);
    const size_t n = (size_t)info.width * info.height;
    float *planes[4];
    uint8_t *valid = (uint8_t *)malloc(n);
    lf_result_buffers_t b;
    lf_result_buffers_init(&b);
    b.width = info.width;
    b.height = info.height;
    lf_plane_t *dst[4] = {&b.u, &b.v, &b.d0, &b.d1};
    for (int k = 0; k < 4; ++k) {
        planes[k] = (float *)malloc(n * sizeof(float));
        if (!planes[k]) return 1;
        dst[k]->data = planes[k];
        dst[k]->stride_bytes = info.width * sizeof(float);
    }
    if (!valid) return 1;
    b.valid.data = valid;
    b.valid.stride_bytes = info.width;
    CHECK(lf_get_result(est, &b), est);

    static const char *outs[4] = {"u.f32", "v.f32", "d0.f32", "d1.f32"};
    char size[64];
    snprintf(size, sizeof size, "%u %u\n", (unsigned)info.width, (unsigned)info.height);
    int ok = write_file(out, "size.txt", size, strlen(size)) && write_file(out, "valid.u8", valid, n);
    for (int k = 0; k < 4; ++k) ok = ok && write_file(out, outs[k], planes[k], n * sizeof(float));
    if (!ok) {
        fprintf(stderr, "consumer: cannot write to %s\n", out);
        return 1;
    }
    printf("lidarflow %s (ABI %u): %ux%u, LiDAR %u + %u points, %.3f s\n", lf_version_string(),
           (unsigned)lf_abi_major(), (unsigned)info.width, (unsigned)info.height, (unsigned)count[0],
           (unsigned)count[1], info.total_seconds);

    lf_destroy(est);
    for (int k = 0; k < 4; ++k) {
        free(planes[k]);
        free(img[k].data);
    }
    free(valid);
    free(xyd[0]);
    free(xyd[1]);
    return 0;
}
