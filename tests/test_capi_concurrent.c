/* SPDX-License-Identifier: MIT */
/* C ABI under concurrency, as the header promises it: distinct handles on distinct threads at
 * the same time, a handle handed from thread to thread between rounds (one thread at a time),
 * and per-thread lf_last_error(NULL) messages. Every result must equal the one a lone handle
 * computes for the same frames. This suite is also what `tools/dev.sh test-tsan` runs under
 * ThreadSanitizer (LF_TEST_THREADS / LF_TEST_ROUNDS size it). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capi_scene.h"

#define W 96
#define H 64
#define SCENES 3
#define MAX_THREADS 16

typedef struct shared_t {
    scene_t scenes[SCENES];
    scene_result_t reference[SCENES];
    lf_estimator_t *handles[MAX_THREADS];
    pthread_barrier_t barrier;
    int threads, rounds;
} shared_t;

typedef struct worker_t {
    shared_t *shared;
    int index;
    char failure[256]; /* "" when everything matched */
} worker_t;

static int env_int(const char *name, int fallback, int lo, int hi) {
    const char *v = getenv(name);
    const int n = v ? atoi(v) : fallback;
    return n < lo ? lo : n > hi ? hi : n;
}

static lf_estimator_t *new_estimator(const scene_t *s) {
    lf_options_t *o = scene_options(1); /* OpenMP's own threads are not what is tested here */
    lf_calibration_t c = scene_calibration(s);
    lf_estimator_t *e = NULL;
    if (!o || lf_create(o, &c, &e) != LF_OK) e = NULL;
    lf_options_destroy(o);
    return e;
}

/* Round r: worker i drives handle (i + r) % threads through scene (i + r) % SCENES. */
static void *work(void *arg) {
    worker_t *w = (worker_t *)arg;
    shared_t *sh = w->shared;
    w->failure[0] = '\0';
    for (int r = 0; r < sh->rounds; ++r) {
        pthread_barrier_wait(&sh->barrier);
        if (w->failure[0]) continue; /* keep meeting the barrier */
        const int k = (w->index + r) % SCENES;
        lf_estimator_t *e = sh->handles[(w->index + r) % sh->threads];
        /* A failing handle-less call on this thread: its message is this thread's alone. */
        char key[64];
        snprintf(key, sizeof key, "no.such.key.%d.%d", w->index, r);
        lf_options_t *o = NULL;
        if (lf_options_create(&o) != LF_OK || lf_options_set_int(o, key, 1) == LF_OK) {
            snprintf(w->failure, sizeof w->failure, "round %d: options call did not fail", r);
            lf_options_destroy(o);
            continue;
        }
        lf_options_destroy(o);
        const int32_t st = scene_push_pair(e, &sh->scenes[k], (int64_t)(r + 1) * 1000000, 1);
        scene_result_t res;
        memset(&res, 0, sizeof res);
        if (st != LF_OK || scene_result_fetch(e, &res) != LF_OK)
            snprintf(w->failure, sizeof w->failure, "round %d: %s", r, lf_last_error(e));
        else if (!scene_result_equal(&res, &sh->reference[k]))
            snprintf(w->failure, sizeof w->failure, "round %d: result differs from the lone handle's", r);
        else if (!strstr(lf_last_error(NULL), key))
            snprintf(w->failure, sizeof w->failure, "round %d: thread message '%s' lacks '%s'", r,
                     lf_last_error(NULL), key);
        scene_result_free(&res);
    }
    return NULL;
}

static void handles_on_threads_match_lone_results(void **state) {
    (void)state;
    static shared_t sh;
    sh.threads = env_int("LF_TEST_THREADS", 4, 1, MAX_THREADS);
    sh.rounds = env_int("LF_TEST_ROUNDS", 6, 1, 1000);
    for (int k = 0; k < SCENES; ++k) {
        assert_true(scene_make(&sh.scenes[k], W, H, 6 + 2 * k, 2 + k, 1, 11u + (uint32_t)k));
        lf_estimator_t *e = new_estimator(&sh.scenes[k]);
        assert_non_null(e);
        assert_int_equal(scene_push_pair(e, &sh.scenes[k], 0, 1), LF_OK);
        assert_int_equal(scene_result_fetch(e, &sh.reference[k]), LF_OK);
        lf_destroy(e);
    }
    /* All scenes share one camera, so any handle can take any scene. */
    for (int i = 0; i < sh.threads; ++i) {
        sh.handles[i] = new_estimator(&sh.scenes[0]);
        assert_non_null(sh.handles[i]);
    }
    assert_int_equal(pthread_barrier_init(&sh.barrier, NULL, (unsigned)sh.threads), 0);
    pthread_t tid[MAX_THREADS];
    worker_t workers[MAX_THREADS];
    for (int i = 0; i < sh.threads; ++i) {
        workers[i].shared = &sh;
        workers[i].index = i;
        assert_int_equal(pthread_create(&tid[i], NULL, work, &workers[i]), 0);
    }
    for (int i = 0; i < sh.threads; ++i) assert_int_equal(pthread_join(tid[i], NULL), 0);
    pthread_barrier_destroy(&sh.barrier);
    for (int i = 0; i < sh.threads; ++i) {
        if (workers[i].failure[0]) fail_msg("thread %d: %s", i, workers[i].failure);
        lf_destroy(sh.handles[i]);
    }
    for (int k = 0; k < SCENES; ++k) {
        scene_result_free(&sh.reference[k]);
        scene_free(&sh.scenes[k]);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(handles_on_threads_match_lone_results),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
