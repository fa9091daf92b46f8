/* SPDX-License-Identifier: MIT */
/* C ABI: lf_set_log_callback. Silent by default; a frame whose LiDAR points partly lie behind
 * the camera or outside the image says so, naming the handle and frame; levels filter; a
 * callback may replace itself; and under concurrency (frames on several threads while the
 * callback is replaced) no callback runs after lf_set_log_callback has replaced it.
 * Compiled as C99 against the public header only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "capi_scene.h"

#define W 96
#define H 64
#define MAX_MESSAGES 64

typedef struct sink_t {
    pthread_mutex_t mutex;
    int count;
    int retired;          /* set once lf_set_log_callback replaced this sink */
    int calls_after_retirement;
    int32_t levels[MAX_MESSAGES];
    char messages[MAX_MESSAGES][512];
} sink_t;

static void sink_init(sink_t *s) {
    memset(s, 0, sizeof *s);
    pthread_mutex_init(&s->mutex, NULL);
}

static void collect(int32_t level, const char *message, void *user) {
    sink_t *s = (sink_t *)user;
    pthread_mutex_lock(&s->mutex);
    if (s->retired) ++s->calls_after_retirement;
    if (s->count < MAX_MESSAGES) {
        s->levels[s->count] = level;
        snprintf(s->messages[s->count], sizeof s->messages[0], "%s", message);
    }
    ++s->count;
    pthread_mutex_unlock(&s->mutex);
}

/* Index of the first message holding every one of the NULL-terminated needles, or -1. */
static int find_message(sink_t *s, const char *a, const char *b, const char *c) {
    pthread_mutex_lock(&s->mutex);
    int found = -1;
    for (int i = 0; i < s->count && i < MAX_MESSAGES && found < 0; ++i)
        if (strstr(s->messages[i], a) && (!b || strstr(s->messages[i], b)) && (!c || strstr(s->messages[i], c)))
            found = i;
    pthread_mutex_unlock(&s->mutex);
    return found;
}

static lf_estimator_t *new_estimator(const scene_t *s) {
    lf_options_t *o = scene_options(1);
    lf_calibration_t c = scene_calibration(s);
    lf_estimator_t *e = NULL;
    /* Stage 1 only: the messages of interest come before it, and the suite stays quick. The
     * paper's stage 1: the decoupled one warns, rightly, that no rigid motion fits a scene this
     * small, and the warnings counted here are the LiDAR's alone. */
    if (!o || lf_options_set_string(o, "preset", "paper") != LF_OK ||
        lf_options_set_string(o, "last_stage", "matching") != LF_OK || lf_create(o, &c, &e) != LF_OK)
        e = NULL;
    lf_options_destroy(o);
    return e;
}

/* Points in the camera frame: `inside` at 5 m in front of the image, 3 behind the camera and
 * 4 far to the left of it. */
static lf_lidar_t camera_points(float *xyz, int inside) {
    int n = 0;
    for (int i = 0; i < inside; ++i, ++n) { /* x = (u - cx) z / fx with fx 100, cx 48 */
        xyz[3 * n + 0] = (float)(((i * 7) % W) - W / 2) * 5.0f / 100.0f;
        xyz[3 * n + 1] = (float)(((i * 5) % H) - H / 2) * 5.0f / 100.0f;
        xyz[3 * n + 2] = 5.0f;
    }
    for (int i = 0; i < 3; ++i, ++n) {
        xyz[3 * n + 0] = 0.5f;
        xyz[3 * n + 1] = 0.0f;
        xyz[3 * n + 2] = -2.0f;
    }
    for (int i = 0; i < 4; ++i, ++n) {
        xyz[3 * n + 0] = -100.0f - (float)i;
        xyz[3 * n + 1] = 0.0f;
        xyz[3 * n + 2] = 5.0f;
    }
    lf_lidar_t l;
    memset(&l, 0, sizeof l);
    l.kind = LF_LIDAR_POINTS_CAMERA;
    l.count = (uint32_t)n;
    l.data = xyz;
    return l;
}

/* The scene's two frames in turn: consecutive pushes never repeat a frame, which the input checks
 * would warn about (a frozen camera). */
static int32_t push(lf_estimator_t *e, const scene_t *s, int64_t t, const lf_lidar_t *lidar) {
    static __thread unsigned turn; /* per thread: pushers on other handles keep their own turn */
    const int second = (int)(turn++ & 1u);
    const lf_image_t l = scene_image(second ? s->left1 : s->left0, s->width, s->height);
    const lf_image_t r = scene_image(second ? s->right1 : s->right0, s->width, s->height);
    return lf_push_frame(e, t, &l, &r, lidar);
}

static void dropped_points_are_reported(void **state) {
    (void)state;
    scene_t s;
    assert_true(scene_make(&s, W, H, 10, 2, 1, 7u));
    lf_estimator_t *e = new_estimator(&s);
    assert_non_null(e);
    float xyz[3 * 40];
    const lf_lidar_t lidar = camera_points(xyz, 20);

    /* Default: silent (nothing to observe but that nothing crashes without a callback). */
    assert_int_equal(push(e, &s, 1000, &lidar), LF_OK);

    static sink_t sink;
    sink_init(&sink);
    assert_int_equal(lf_set_log_callback(collect, LF_LOG_INFO, &sink), LF_OK);
    assert_int_equal(push(e, &s, 2000, &lidar), LF_OK);
    char handle[64];
    snprintf(handle, sizeof handle, "estimator %p frame 2000 us", (void *)e);
    const int i = find_message(&sink, handle, "7 of 27 LiDAR points dropped", "3 behind the camera");
    if (i < 0) fail_msg("no drop message naming '%s' among %d messages (first: '%s')", handle, sink.count,
                        sink.count ? sink.messages[0] : "");
    assert_int_equal(sink.levels[i], LF_LOG_INFO);
    assert_non_null(strstr(sink.messages[i], "4 outside the 96x64 image"));

    /* Disparity entries alike: those whose nearest pixel is off the image are dropped and said. */
    const float xyd[4 * 3] = {10, 10, 5, 95.4f, 63.4f, 5, -3, 10, 5, 40, 63.6f, 5};
    lf_lidar_t disparities;
    memset(&disparities, 0, sizeof disparities);
    disparities.kind = LF_LIDAR_DISPARITY;
    disparities.count = 4;
    disparities.data = xyd;
    assert_int_equal(push(e, &s, 2500, &disparities), LF_OK);
    const int j = find_message(&sink, "frame 2500 us", "2 of 4 LiDAR points dropped: 2 outside the 96x64 image",
                               "2 pixels keep a point");
    if (j < 0) fail_msg("no drop message for disparity entries among %d messages", sink.count);

    /* Every point dropped is a warning; a warning-level callback sees it but not the info. */
    static sink_t warnings;
    sink_init(&warnings);
    assert_int_equal(lf_set_log_callback(collect, LF_LOG_WARNING, &warnings), LF_OK);
    const lf_lidar_t outside = camera_points(xyz, 0);
    assert_int_equal(push(e, &s, 3000, &lidar), LF_OK);
    assert_int_equal(warnings.count, 0);
    assert_int_equal(push(e, &s, 4000, &outside), LF_OK);
    const int w = find_message(&warnings, "frame 4000 us", "7 of 7 LiDAR points dropped", NULL);
    assert_true(w >= 0);
    assert_int_equal(warnings.levels[w], LF_LOG_WARNING);

    /* Levels outside the enum are refused and change nothing; NULL silences. */
    assert_int_equal(lf_set_log_callback(collect, 41, &sink), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_last_error(NULL), "min_level 41"));
    assert_int_equal(lf_set_log_callback(collect, 9, &sink), LF_ERR_INVALID_ARGUMENT);
    const int before = warnings.count;
    assert_int_equal(push(e, &s, 5000, &outside), LF_OK);
    assert_int_equal(warnings.count, before + 1);
    assert_int_equal(lf_set_log_callback(NULL, 0, NULL), LF_OK);
    assert_int_equal(push(e, &s, 6000, &outside), LF_OK);
    assert_int_equal(warnings.count, before + 1);
    lf_destroy(e);
    scene_free(&s);
}

/* A callback that replaces itself returns (it does not wait for its own call). */
static sink_t g_self;
static void replace_self(int32_t level, const char *message, void *user) {
    collect(level, message, user);
    lf_set_log_callback(NULL, 0, NULL);
}

static void callback_may_replace_itself(void **state) {
    (void)state;
    scene_t s;
    assert_true(scene_make(&s, W, H, 10, 2, 1, 7u));
    lf_estimator_t *e = new_estimator(&s);
    assert_non_null(e);
    float xyz[3 * 40];
    const lf_lidar_t lidar = camera_points(xyz, 20);
    sink_init(&g_self);
    assert_int_equal(lf_set_log_callback(replace_self, LF_LOG_DEBUG, &g_self), LF_OK);
    assert_int_equal(push(e, &s, 1000, &lidar), LF_OK);
    assert_int_equal(push(e, &s, 2000, &lidar), LF_OK);
    assert_int_equal(g_self.count, 1);
    lf_destroy(e);
    scene_free(&s);
}

/* Frames on several threads while the main thread keeps replacing the callback: once
 * lf_set_log_callback returns, the replaced callback's user data is never touched again. */
#define THREADS 3
#define GENERATIONS 40

typedef struct pusher_t {
    const scene_t *scene;
    volatile int *stop;
    int32_t status;
} pusher_t;

static void *pusher(void *arg) {
    pusher_t *p = (pusher_t *)arg;
    lf_estimator_t *e = new_estimator(p->scene);
    float xyz[3 * 40];
    const lf_lidar_t lidar = camera_points(xyz, 20);
    p->status = e ? LF_OK : LF_ERR_INTERNAL;
    for (int64_t t = 1; e && p->status == LF_OK && !__atomic_load_n(p->stop, __ATOMIC_ACQUIRE); ++t) {
        p->status = push(e, p->scene, t * 1000, &lidar);
        /* Two frames per sequence: stage 1 runs only on the second. */
        if (t % 2 == 0 && p->status == LF_OK) p->status = lf_reset(e);
    }
    lf_destroy(e);
    return NULL;
}

static void replacing_while_frames_run(void **state) {
    (void)state;
    scene_t s;
    assert_true(scene_make(&s, W, H, 10, 2, 1, 7u));
    static sink_t sinks[GENERATIONS];
    volatile int stop = 0;
    pusher_t p[THREADS];
    pthread_t tid[THREADS];
    sink_init(&sinks[0]);
    assert_int_equal(lf_set_log_callback(collect, LF_LOG_DEBUG, &sinks[0]), LF_OK);
    for (int i = 0; i < THREADS; ++i) {
        p[i].scene = &s;
        p[i].stop = &stop;
        p[i].status = LF_OK;
        assert_int_equal(pthread_create(&tid[i], NULL, pusher, &p[i]), 0);
    }
    int delivered = 0;
    for (int g = 1; g < GENERATIONS; ++g) {
        /* Wait until the current sink has seen a message, so that replacements race with calls. */
        for (int spin = 0; spin < 20000; ++spin) {
            pthread_mutex_lock(&sinks[g - 1].mutex);
            const int n = sinks[g - 1].count;
            pthread_mutex_unlock(&sinks[g - 1].mutex);
            if (n > 0) break;
            struct timespec ts = {0, 100000};
            nanosleep(&ts, NULL);
        }
        sink_init(&sinks[g]);
        assert_int_equal(lf_set_log_callback(collect, LF_LOG_DEBUG, &sinks[g]), LF_OK);
        pthread_mutex_lock(&sinks[g - 1].mutex);
        sinks[g - 1].retired = 1;
        delivered += sinks[g - 1].count;
        pthread_mutex_unlock(&sinks[g - 1].mutex);
    }
    assert_int_equal(lf_set_log_callback(NULL, 0, NULL), LF_OK);
    pthread_mutex_lock(&sinks[GENERATIONS - 1].mutex);
    sinks[GENERATIONS - 1].retired = 1;
    pthread_mutex_unlock(&sinks[GENERATIONS - 1].mutex);
    __atomic_store_n(&stop, 1, __ATOMIC_RELEASE);
    for (int i = 0; i < THREADS; ++i) assert_int_equal(pthread_join(tid[i], NULL), 0);
    for (int i = 0; i < THREADS; ++i) assert_int_equal(p[i].status, LF_OK);
    for (int g = 0; g < GENERATIONS; ++g)
        if (sinks[g].calls_after_retirement) fail_msg("sink %d called %d times after it was replaced", g,
                                                      sinks[g].calls_after_retirement);
    assert_true(delivered >= GENERATIONS - 1);
    scene_free(&s);
}

/* A log callback that calls lf_push_frame and lf_reset on the estimator whose push is logging:
 * both are refused (LF_ERR_BAD_STATE) and the outer push's result is what it would have been. */
typedef struct reentry_t {
    lf_estimator_t *e;
    const scene_t *s;
    int calls;
    int32_t push_status, reset_status;
} reentry_t;

static void reenter(int32_t level, const char *message, void *user) {
    (void)level;
    (void)message;
    reentry_t *r = (reentry_t *)user;
    if (r->calls++ > 0) return;
    r->push_status = push(r->e, r->s, 999000, NULL);
    r->reset_status = lf_reset(r->e);
}

static void reentry_is_refused(void **state) {
    (void)state;
    scene_t s;
    assert_true(scene_make(&s, W, H, 10, 2, 1, 7u));
    lf_estimator_t *e = new_estimator(&s), *plain = new_estimator(&s);
    assert_non_null(e);
    assert_non_null(plain);
    float xyz[3 * 40];
    const lf_lidar_t lidar = camera_points(xyz, 20); /* its dropped points are logged */
    assert_int_equal(push(e, &s, 1000, &lidar), LF_OK);
    assert_int_equal(push(plain, &s, 1000, &lidar), LF_OK);
    static reentry_t r;
    memset(&r, 0, sizeof r);
    r.e = e;
    r.s = &s;
    assert_int_equal(lf_set_log_callback(reenter, LF_LOG_DEBUG, &r), LF_OK);
    assert_int_equal(push(e, &s, 2000, &lidar), LF_OK);
    assert_int_equal(lf_set_log_callback(NULL, 0, NULL), LF_OK);
    assert_true(r.calls > 0);
    assert_int_equal(r.push_status, LF_ERR_BAD_STATE);
    assert_int_equal(r.reset_status, LF_ERR_BAD_STATE);
    assert_int_equal(push(plain, &s, 2000, &lidar), LF_OK);
    assert_int_equal(lf_has_result(e), 1);
    lf_result_info_t a, b;
    lf_result_info_init(&a);
    lf_result_info_init(&b);
    assert_int_equal(lf_get_result_info(e, &a), LF_OK);
    assert_int_equal(lf_get_result_info(plain, &b), LF_OK);
    assert_true(a.t0_us == 1000 && a.t1_us == 2000 && b.t0_us == 1000);
    /* After the call the handle takes calls again. */
    assert_int_equal(lf_reset(e), LF_OK);
    lf_destroy(e);
    lf_destroy(plain);
    scene_free(&s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(dropped_points_are_reported),
        cmocka_unit_test(callback_may_replace_itself),
        cmocka_unit_test(replacing_while_frames_run),
        cmocka_unit_test(reentry_is_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
