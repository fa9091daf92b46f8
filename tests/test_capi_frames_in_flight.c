/* SPDX-License-Identifier: MIT */
/* C ABI: the option "frames_in_flight". A handle with N > 1 pairs in flight hands each pair
 * over N - 1 pushes late, in order: here (a plane, no movers, so no motion prior) its result
 * equal bit for bit to the pair computed on its own (lf_reset before each pair on a handle of
 * one pair at a time), or, for a pair that failed, no result and its error. The movers' prior
 * is checked against `lidarflow sequence --frames-in-flight` (test_sequence_cli). lf_flush hands over the rest, lf_reset drops them, and a frame worker's
 * log callback cannot wait for its own pair. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capi_scene.h"

#define W 96
#define H 64
#define FRAMES 7
#define D 8
#define TU 2

/* Frame k of a drive past a textured plane at disparity D: the texture moves TU px a frame,
 * one row every other frame. Frame BLACK is black: the estimator refuses its two pairs when it
 * runs them (nothing to match), so they are handed over without a result. */
#define BLACK 4
static uint8_t left_of[FRAMES][W * H], right_of[FRAMES][W * H];

static void make_frames(void) {
    for (int k = 0; k < FRAMES; ++k)
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const int sx = x - k * TU, sy = y - k / 2;
                left_of[k][y * W + x] = k == BLACK ? 0 : scene_world(sx, sy, 5u);
                right_of[k][y * W + x] = k == BLACK ? 0 : scene_world(sx + D, sy, 5u);
            }
}

static lf_calibration_t calibration(void) {
    scene_t s;
    memset(&s, 0, sizeof s);
    s.width = W;
    s.height = H;
    return scene_calibration(&s);
}

static lf_estimator_t *new_estimator(int threads, int in_flight) {
    lf_options_t *o = scene_options(threads);
    assert_non_null(o);
    assert_int_equal(lf_options_set_int(o, "frames_in_flight", in_flight), LF_OK);
    const lf_calibration_t c = calibration();
    lf_estimator_t *e = NULL;
    if (lf_create(o, &c, &e) != LF_OK) fail_msg("lf_create: %s", lf_last_error(NULL));
    lf_options_destroy(o);
    return e;
}

static int64_t stamp(int k) { return 1000000 + 100000 * (int64_t)k; }

static int32_t push(lf_estimator_t *e, int k) {
    const lf_image_t l = scene_image(left_of[k], W, H), r = scene_image(right_of[k], W, H);
    return lf_push_frame(e, stamp(k), &l, &r, NULL);
}

/* Pair k -> k + 1 on its own: its status and (when LF_OK) its result. */
static int32_t status_of[FRAMES - 1];
static scene_result_t reference[FRAMES - 1];

static int setup(void **state) {
    (void)state;
    make_frames();
    /* One OpenMP thread per pair everywhere: the suite also runs under ThreadSanitizer, which
     * does not see libgomp's barriers (tools/dev.sh test-tsan). */
    lf_estimator_t *e = new_estimator(1, 1);
    for (int k = 0; k + 1 < FRAMES; ++k) {
        memset(&reference[k], 0, sizeof reference[k]);
        if (lf_reset(e) != LF_OK || push(e, k) != LF_OK) return -1;
        status_of[k] = push(e, k + 1);
        if (status_of[k] == LF_OK && scene_result_fetch(e, &reference[k]) != LF_OK) return -1;
    }
    lf_destroy(e);
    /* The stream needs good pairs on both sides of the failed ones. */
    return status_of[BLACK - 2] == LF_OK && status_of[BLACK - 1] != LF_OK && status_of[BLACK] != LF_OK &&
                   status_of[BLACK + 1] == LF_OK
               ? 0
               : -1;
}

static int teardown(void **state) {
    (void)state;
    for (int k = 0; k + 1 < FRAMES; ++k) scene_result_free(&reference[k]);
    return 0;
}

/* The pair handed over last is pair k: its timestamps and fields, or its error. */
static void expect_pair(lf_estimator_t *e, int k) {
    lf_result_info_t info;
    lf_result_info_init(&info);
    if (status_of[k] != LF_OK) {
        assert_int_equal(lf_has_result(e), 0);
        assert_int_equal(lf_get_result_info(e, &info), status_of[k]);
        char pair[64];
        snprintf(pair, sizeof pair, "pair %lld -> %lld us", (long long)stamp(k), (long long)stamp(k + 1));
        if (!strstr(lf_last_error(e), pair)) fail_msg("message '%s' lacks '%s'", lf_last_error(e), pair);
        return;
    }
    assert_int_equal(lf_has_result(e), 1);
    assert_int_equal(lf_get_result_info(e, &info), LF_OK);
    assert_int_equal(info.t0_us, stamp(k));
    assert_int_equal(info.t1_us, stamp(k + 1));
    if (!scene_result_matches(e, &reference[k])) fail_msg("pair %d differs from the pair computed on its own", k);
}

static void results_come_late_in_order_and_equal_single_pairs(void **state) {
    (void)state;
    for (int n = 2; n <= 3; ++n) {
        lf_estimator_t *e = new_estimator(n, n);
        int handed = 0;
        for (int k = 0; k < FRAMES; ++k) {
            assert_int_equal(push(e, k), LF_OK);
            /* Pair j (frames j, j + 1) comes with the push of frame j + n. */
            if (k >= n) {
                expect_pair(e, k - n);
                ++handed;
            } else {
                assert_int_equal(lf_has_result(e), 0);
                assert_int_equal(lf_get_result_info(e, &(lf_result_info_t){.struct_size = sizeof(lf_result_info_t)}),
                                 LF_ERR_NOT_READY);
            }
        }
        while (lf_flush(e) == LF_OK) expect_pair(e, handed++);
        assert_int_equal(handed, FRAMES - 1);
        assert_int_equal(lf_flush(e), LF_ERR_NOT_READY);
        expect_pair(e, FRAMES - 2); /* the last one stays current */
        lf_destroy(e);
    }
}

static void flush_without_pairs_in_flight(void **state) {
    (void)state;
    lf_estimator_t *one = new_estimator(1, 1);
    assert_int_equal(lf_flush(one), LF_ERR_NOT_READY);
    assert_int_equal(push(one, 0), LF_OK);
    assert_int_equal(push(one, 1), LF_OK);
    assert_int_equal(lf_flush(one), LF_ERR_NOT_READY); /* the push computed it */
    expect_pair(one, 0);
    lf_destroy(one);
    assert_int_equal(lf_flush(NULL), LF_ERR_INVALID_ARGUMENT);
}

static void reset_drops_pairs_in_flight(void **state) {
    (void)state;
    lf_estimator_t *e = new_estimator(3, 3);
    for (int k = 0; k < 3; ++k) assert_int_equal(push(e, k), LF_OK);
    assert_int_equal(lf_reset(e), LF_OK);
    assert_int_equal(lf_flush(e), LF_ERR_NOT_READY);
    assert_int_equal(lf_has_result(e), 0);
    /* A new sequence may start anywhere, even before the dropped frames' timestamps. */
    assert_int_equal(push(e, 2), LF_OK);
    assert_int_equal(push(e, 3), LF_OK);
    assert_int_equal(lf_flush(e), LF_OK);
    expect_pair(e, 2);
    /* Destroyed with a pair in flight: waits for it. */
    assert_int_equal(push(e, 4), LF_OK);
    lf_destroy(e);
}

/* After a flush in mid-stream the pipeline fills again: a push that hands nothing over leaves no
 * result (not the flushed one again), and later pairs are as before. */
static void push_after_flush_hands_over_nothing(void **state) {
    (void)state;
    lf_estimator_t *e = new_estimator(2, 2);
    for (int k = 0; k < 3; ++k) assert_int_equal(push(e, k), LF_OK);
    expect_pair(e, 0);
    assert_int_equal(lf_flush(e), LF_OK);
    expect_pair(e, 1);
    assert_int_equal(push(e, 3), LF_OK);
    assert_int_equal(lf_has_result(e), 0);
    assert_int_equal(lf_get_result_info(e, &(lf_result_info_t){.struct_size = sizeof(lf_result_info_t)}),
                     LF_ERR_NOT_READY);
    assert_int_equal(push(e, 4), LF_OK);
    expect_pair(e, 2);
    assert_int_equal(lf_flush(e), LF_OK);
    expect_pair(e, 3);
    lf_destroy(e);
}

/* Any increasing int64 timestamps are accepted, the most distant too (the time steps saturate
 * rather than overflow: UBSan checks it). */
static void extreme_timestamps(void **state) {
    (void)state;
    const int64_t stamps[] = {INT64_MIN, -1, INT64_MAX};
    for (int n = 1; n <= 2; ++n) {
        lf_estimator_t *e = new_estimator(n, n);
        for (int k = 0; k < 3; ++k) {
            const lf_image_t l = scene_image(left_of[k], W, H), r = scene_image(right_of[k], W, H);
            assert_int_equal(lf_push_frame(e, stamps[k], &l, &r, NULL), LF_OK);
        }
        if (n > 1) assert_int_equal(lf_flush(e), LF_OK);
        lf_result_info_t info;
        lf_result_info_init(&info);
        assert_int_equal(lf_get_result_info(e, &info), LF_OK);
        assert_true(info.t0_us == -1 && info.t1_us == INT64_MAX);
        lf_destroy(e);
    }
}

/* A frame worker's callback may not wait for its own pair (that would never return), nor read
 * the result its owner's thread may be replacing. */
typedef struct reentry_t {
    lf_estimator_t *e;
    pthread_t caller;
    /* Two frame workers may log at once. */
    atomic_int worker_calls; /* callback calls on a frame worker */
    atomic_int refused;      /* ... whose lf_flush, lf_reset and result reads were refused with LF_ERR_BAD_STATE */
} reentry_t;

static void reenter(int32_t level, const char *message, void *user) {
    (void)level;
    (void)message;
    reentry_t *r = (reentry_t *)user;
    if (pthread_equal(pthread_self(), r->caller)) return;
    ++r->worker_calls;
    lf_result_info_t info;
    lf_result_info_init(&info);
    r->refused += lf_flush(r->e) == LF_ERR_BAD_STATE && strstr(lf_last_error(NULL), "lf_flush") &&
                  lf_reset(r->e) == LF_ERR_BAD_STATE && lf_get_result_info(r->e, &info) == LF_ERR_BAD_STATE &&
                  strstr(lf_last_error(r->e), "lf_get_result_info") && lf_has_result(r->e) == 0;
}

static void worker_callback_cannot_wait_for_itself(void **state) {
    (void)state;
    static reentry_t r;
    r.e = new_estimator(2, 2);
    r.caller = pthread_self();
    r.worker_calls = r.refused = 0;
    /* Frame 0 three times: each frozen pair's input quality is logged by the worker that
     * computes it, the second while the first is the handle's result. */
    assert_int_equal(lf_set_log_callback(reenter, LF_LOG_WARNING, &r), LF_OK);
    const lf_image_t l = scene_image(left_of[0], W, H), rr = scene_image(right_of[0], W, H);
    for (int64_t t = 1; t <= 3; ++t) assert_int_equal(lf_push_frame(r.e, t, &l, &rr, NULL), LF_OK);
    assert_int_equal(lf_has_result(r.e), 1);
    assert_int_equal(lf_flush(r.e), LF_OK);
    assert_int_equal(lf_set_log_callback(NULL, 0, NULL), LF_OK);
    assert_true(r.worker_calls > 0);
    assert_int_equal(r.refused, r.worker_calls);
    assert_int_equal(lf_has_result(r.e), 1); /* its own pair was not disturbed */
    lf_destroy(r.e);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(results_come_late_in_order_and_equal_single_pairs),
        cmocka_unit_test(flush_without_pairs_in_flight),
        cmocka_unit_test(reset_drops_pairs_in_flight),
        cmocka_unit_test(push_after_flush_hands_over_nothing),
        cmocka_unit_test(extreme_timestamps),
        cmocka_unit_test(worker_callback_cannot_wait_for_itself),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
