/* SPDX-License-Identifier: MIT */
/* C ABI: lf_options_* — every key's documented default and bounds (both ends), types, NULLs,
 * presets, and that a failed set leaves the object unchanged with a message naming the key.
 * Compiled as C99 against the public header only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "lidarflow/lidarflow.h"

enum kind { INT, BOOL, FLOAT };
enum extra { NONE, ODD, MULT16, POW2 };

/* The table of include/lidarflow/lidarflow.h, as a caller reads it. */
typedef struct key_t_ {
    const char *key;
    enum kind kind;
    double lo, hi;
    int lo_open;
    enum extra extra;
    double def; /* documented default; NAN: the core's tuned value, only bounded */
} key_t_;

static const key_t_ kKeys[] = {
    {"threads", INT, 1, 256, 0, NONE, NAN}, /* the usable CPUs: test_cpp_api checks it */
    {"use_lidar", BOOL, 0, 1, 0, NONE, 1},
    {"input.strict", BOOL, 0, 1, 0, NONE, 0},
    {"processing_scale", FLOAT, 0.125, 1, 0, NONE, 0.65}, /* the "default" preset's */
    {"support_window", INT, 1, 101, 0, ODD, 15},
    {"lidar.visibility_filter", BOOL, 0, 1, 0, NONE, 1},
    {"lidar.visibility_half_width", INT, 0, 64, 0, NONE, 6},
    {"lidar.visibility_half_height", INT, 0, 64, 0, NONE, 0},
    {"lidar.visibility_ratio", FLOAT, 0, 10, 0, NONE, 0.05f}, /* stored as float32 */
    {"lidar.visibility_margin", FLOAT, 0, 16384, 0, NONE, 1},
    {"matching.support_windows", BOOL, 0, 1, 0, NONE, NAN},
    {"matching.const1", BOOL, 0, 1, 0, NONE, NAN},
    {"matching.const2", BOOL, 0, 1, 0, NONE, NAN},
    {"matching.use_lidar1", BOOL, 0, 1, 0, NONE, NAN},
    {"matching.keep_disparity_change", BOOL, 0, 1, 0, NONE, 1},
    {"matching.d1_terms_anchored", BOOL, 0, 1, 0, NONE, 0},
    {"matching.grid_step", INT, 1, 32, 0, NONE, NAN},
    {"matching.backward_grid_step", INT, 0, 32, 0, NONE, 0},
    {"matching.iterations", INT, 1, 100, 0, NONE, NAN},
    {"matching.thin_from_level", INT, 1, 100, 0, NONE, NAN},
    {"matching.max_levels", INT, 1, 10, 0, NONE, NAN},
    {"matching.min_coarsest_height", INT, 8, 4096, 0, NONE, NAN},
    {"matching.lazy_random_search", BOOL, 0, 1, 0, NONE, NAN},
    {"matching.settle_ratio", FLOAT, 0, 100, 0, NONE, 1},
    {"matching.descriptor_bits", INT, 4, 8, 0, POW2, 8},
    {"matching.patch_radius", INT, 0, 16, 0, NONE, NAN},
    {"matching.stop_ratio", FLOAT, 0, 1, 0, NONE, NAN},
    {"matching.max_flow", FLOAT, 1, 10000, 0, NONE, NAN},
    {"matching.max_disparity", FLOAT, 1, 10000, 0, NONE, NAN},
    {"matching.const2_abs", FLOAT, 0, 10000, 0, NONE, NAN},
    {"matching.const2_rel", FLOAT, 0, 10, 0, NONE, NAN},
    {"matching.random_seed", INT, 0, 9007199254740992.0, 0, NONE, NAN},
    {"consistency.sgm_max_diff", FLOAT, 0, 10000, 1, NONE, NAN},
    {"consistency.sgm_keep_unverified", BOOL, 0, 1, 0, NONE, NAN},
    {"consistency.sgm_num_disparities", INT, 16, 1024, 0, MULT16, NAN},
    {"consistency.sgm_block_size", INT, 1, 31, 0, ODD, NAN},
    {"consistency.fb_max_flow", FLOAT, 0, 10000, 1, NONE, NAN},
    {"consistency.fb_max_d0", FLOAT, 0, 10000, 1, NONE, NAN},
    {"consistency.fb_max_d1", FLOAT, 0, 10000, 1, NONE, NAN},
    {"consistency.fb_search_radius", INT, 0, 8, 0, NONE, NAN},
    {"consistency.keep_unreliable_lidar", BOOL, 0, 1, 0, NONE, NAN},
    {"consistency.cluster_max_flow_step", FLOAT, 0, 10000, 1, NONE, NAN},
    {"consistency.cluster_max_disp_step", FLOAT, 0, 10000, 1, NONE, NAN},
    {"consistency.cluster_min_size", INT, 1, 100000000, 0, NONE, NAN},
    {"consistency.keep_lidar_clusters", BOOL, 0, 1, 0, NONE, NAN},
    {"consistency.sparsify_block", INT, 1, 64, 0, NONE, NAN},
    {"consistency.sparsify_support", INT, 1, 63, 0, ODD, NAN},
    {"interpolation.use_lidar", BOOL, 0, 1, 0, NONE, NAN},
    {"interpolation.superpixel_size", INT, 4, 512, 0, NONE, NAN},
    {"interpolation.num_neighbors", INT, 1, 4096, 0, NONE, 256},
    {"interpolation.iterations", INT, 0, 1000, 0, NONE, NAN},
    {"interpolation.initial_hypotheses", INT, 1, 10000, 0, NONE, NAN},
    {"interpolation.random_hypotheses", INT, 0, 10000, 0, NONE, NAN},
    {"interpolation.edge_gain", FLOAT, 0, 10000, 0, NONE, NAN},
    {"interpolation.distance_sigma", FLOAT, 0, 10000, 1, NONE, 36},
    {"interpolation.disparity_inlier", FLOAT, 0, 10000, 1, NONE, NAN},
    {"interpolation.flow_inlier", FLOAT, 0, 10000, 1, NONE, NAN},
    {"interpolation.lidar_anchor_distance", FLOAT, 0, 10000, 0, NONE, NAN},
    {"interpolation.pixel_model_selection", BOOL, 0, 1, 0, NONE, NAN},
    {"interpolation.exits_follow_background", BOOL, 0, 1, 0, NONE, 1},
    {"interpolation.static_d1_from_background", BOOL, 0, 1, 0, NONE, 1},
    {"interpolation.lidar1_from_background", BOOL, 0, 1, 0, NONE, 1},
    {"interpolation.keep_lidar_values", BOOL, 0, 1, 0, NONE, NAN},
    {"interpolation.random_seed", INT, 0, 4294967295.0, 0, NONE, NAN},
};
#define KEY_COUNT (sizeof kKeys / sizeof kKeys[0])

static int setup(void **state) {
    lf_options_t *o = NULL;
    if (lf_options_create(&o) != LF_OK) return -1;
    *state = o;
    return 0;
}

static int teardown(void **state) {
    lf_options_destroy((lf_options_t *)*state);
    return 0;
}

static double get_number(lf_options_t *o, const char *key) {
    double v = -12345;
    assert_int_equal(lf_options_get_float(o, key, &v), LF_OK);
    return v;
}

/* Sets `v` through the key's natural setter (integers exactly, as int64). */
static int32_t set_number(lf_options_t *o, const key_t_ *k, double v, int64_t iv) {
    return k->kind == FLOAT ? lf_options_set_float(o, k->key, v) : lf_options_set_int(o, k->key, iv);
}

/* A rejected value: the documented status, a message naming the key, the value unchanged. */
static void expect_rejected_v(lf_options_t *o, const key_t_ *k, double v, int64_t iv) {
    const double before = get_number(o, k->key);
    const int32_t status = set_number(o, k, v, iv);
    if (status != LF_ERR_INVALID_ARGUMENT)
        fail_msg("%s = %.17g / %lld: status %d", k->key, v, (long long)iv, (int)status);
    assert_non_null(strstr(lf_options_last_error(o), k->key));
    assert_string_equal(lf_last_error(NULL), lf_options_last_error(o));
    assert_true(get_number(o, k->key) == before);
}

static void expect_accepted_v(lf_options_t *o, const key_t_ *k, double v, int64_t iv) {
    if (set_number(o, k, v, iv) != LF_OK) fail_msg("%s = %.17g rejected: %s", k->key, v, lf_options_last_error(o));
    assert_string_equal(lf_options_last_error(o), "");
    if (k->kind == FLOAT) {
        /* float keys are stored as float32 */
        assert_true(fabs(get_number(o, k->key) - v) <= 1e-6 * fabs(v));
    } else {
        int64_t got = -1;
        assert_int_equal(lf_options_get_int(o, k->key, &got), LF_OK);
        assert_true(got == iv);
    }
}

static void expect_rejected(lf_options_t *o, const key_t_ *k, double v) { expect_rejected_v(o, k, v, 0); }
static void expect_accepted(lf_options_t *o, const key_t_ *k, double v) { expect_accepted_v(o, k, v, 0); }
static void expect_rejected_int(lf_options_t *o, const key_t_ *k, int64_t v) { expect_rejected_v(o, k, 0, v); }
static void expect_accepted_int(lf_options_t *o, const key_t_ *k, int64_t v) { expect_accepted_v(o, k, 0, v); }

static void test_defaults_match_documentation(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    for (size_t i = 0; i < KEY_COUNT; ++i) {
        const key_t_ *k = &kKeys[i];
        const double v = get_number(o, k->key);
        if (!isnan(k->def) && v != k->def) fail_msg("%s default %.9g, documented %.9g", k->key, v, k->def);
        /* every default lies inside its documented bounds */
        if (!((k->lo_open ? v > k->lo : v >= k->lo) && v <= k->hi))
            fail_msg("%s default %.9g outside its documented bounds", k->key, v);
        if (k->kind != FLOAT) {
            int64_t iv = -1;
            assert_int_equal(lf_options_get_int(o, k->key, &iv), LF_OK);
            assert_true((double)iv == v);
            if (k->extra == ODD) assert_true(iv % 2 == 1);
            if (k->extra == MULT16) assert_true(iv % 16 == 0);
            if (k->extra == POW2) assert_true(iv > 0 && (iv & (iv - 1)) == 0);
        }
    }
    const char *s = NULL;
    assert_int_equal(lf_options_get_string(o, "preset", &s), LF_OK);
    assert_string_equal(s, "default");
    assert_int_equal(lf_options_get_string(o, "last_stage", &s), LF_OK);
    assert_string_equal(s, "interpolation");
    assert_int_equal(lf_options_get_string(o, "interpolation.sed_model", &s), LF_OK);
    assert_string_equal(s, "");
}

static void test_bounds_of_every_key(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    for (size_t i = 0; i < KEY_COUNT; ++i) {
        const key_t_ *k = &kKeys[i];
        if (k->kind == FLOAT) {
            if (k->lo_open) {
                expect_rejected(o, k, k->lo);
                expect_accepted(o, k, k->lo + 1e-3);
            } else {
                expect_rejected(o, k, k->lo - 1e-3);
                expect_accepted(o, k, k->lo);
            }
            expect_accepted(o, k, k->hi);
            expect_rejected(o, k, k->hi * 1.001 + 1e-3);
            expect_rejected(o, k, NAN);
            expect_rejected(o, k, INFINITY);
            expect_rejected(o, k, -INFINITY);
        } else {
            const int64_t lo = (int64_t)k->lo, hi = (int64_t)k->hi;
            expect_rejected_int(o, k, lo - 1);
            expect_accepted_int(o, k, lo);
            expect_accepted_int(o, k, hi);
            expect_rejected_int(o, k, hi + 1);
            if (k->extra == ODD) expect_rejected_int(o, k, lo + 1);
            if (k->extra == MULT16) {
                expect_rejected_int(o, k, lo + 8);
                expect_accepted_int(o, k, lo + 16);
            }
            if (k->extra == POW2)
                for (int64_t v = lo + 1; v < hi; ++v)
                    if (v & (v - 1)) expect_rejected_int(o, k, v);
            /* integer keys are not floats */
            assert_int_equal(lf_options_set_float(o, k->key, k->lo), LF_ERR_INVALID_ARGUMENT);
            assert_non_null(strstr(lf_options_last_error(o), "lf_options_set_float"));
        }
        assert_int_equal(lf_options_set_string(o, k->key, "1"), LF_ERR_INVALID_ARGUMENT);
    }
    /* INT64 extremes do not wrap into range */
    assert_int_equal(lf_options_set_int(o, "threads", INT64_MAX), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_set_int(o, "threads", INT64_MIN), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_set_int(o, "matching.random_seed", INT64_MIN), LF_ERR_INVALID_ARGUMENT);
}

static void test_float_keys_accept_integers(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    assert_int_equal(lf_options_set_int(o, "consistency.fb_max_flow", 3), LF_OK);
    assert_true(get_number(o, "consistency.fb_max_flow") == 3.0);
    int64_t iv;
    assert_int_equal(lf_options_get_int(o, "consistency.fb_max_flow", &iv), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "lf_options_get_int"));
}

static void test_support_window_sets_both_stages(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    assert_int_equal(lf_options_set_int(o, "support_window", 7), LF_OK);
    assert_true(get_number(o, "support_window") == 7.0);
    assert_int_equal(lf_options_set_int(o, "support_window", 8), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "odd"));
}

static void test_string_keys(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    static const char *stages[] = {"matching", "consistency", "sparse", "interpolation"};
    const char *s = NULL;
    for (int i = 0; i < 4; ++i) {
        assert_int_equal(lf_options_set_string(o, "last_stage", stages[i]), LF_OK);
        assert_int_equal(lf_options_get_string(o, "last_stage", &s), LF_OK);
        assert_string_equal(s, stages[i]);
    }
    assert_int_equal(lf_options_set_string(o, "last_stage", "dense"), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "dense"));
    assert_int_equal(lf_options_get_string(o, "last_stage", &s), LF_OK);
    assert_string_equal(s, "interpolation"); /* unchanged by the failed set */

    assert_int_equal(lf_options_set_string(o, "interpolation.sed_model", "/models/sed.yml.gz"), LF_OK);
    assert_int_equal(lf_options_get_string(o, "interpolation.sed_model", &s), LF_OK);
    assert_string_equal(s, "/models/sed.yml.gz");

    assert_int_equal(lf_options_set_int(o, "last_stage", 1), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_set_float(o, "preset", 1.0), LF_ERR_INVALID_ARGUMENT);
    double d;
    assert_int_equal(lf_options_get_float(o, "preset", &d), LF_ERR_INVALID_ARGUMENT);
    int64_t i64;
    assert_int_equal(lf_options_get_int(o, "last_stage", &i64), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_get_string(o, "threads", &s), LF_ERR_INVALID_ARGUMENT);
}

static void test_preset_resets_all_but_threads(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    assert_int_equal(lf_options_set_int(o, "threads", 3), LF_OK);
    assert_int_equal(lf_options_set_int(o, "matching.grid_step", 5), LF_OK);
    assert_int_equal(lf_options_set_string(o, "last_stage", "sparse"), LF_OK);
    assert_int_equal(lf_options_set_string(o, "interpolation.sed_model", "x.yml"), LF_OK);
    assert_int_equal(lf_options_set_string(o, "preset", "fastest"), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "fastest"));
    assert_true(get_number(o, "matching.grid_step") == 5.0); /* failed preset changed nothing */

    lf_options_t *fresh = NULL;
    assert_int_equal(lf_options_create(&fresh), LF_OK);
    assert_int_equal(lf_options_set_string(o, "preset", "default"), LF_OK);
    assert_true(get_number(o, "threads") == 3.0);
    for (size_t i = 1; i < KEY_COUNT; ++i) /* every key but threads back at its default */
        if (get_number(o, kKeys[i].key) != get_number(fresh, kKeys[i].key)) fail_msg("%s not reset", kKeys[i].key);
    lf_options_destroy(fresh);
    const char *s;
    assert_int_equal(lf_options_get_string(o, "last_stage", &s), LF_OK);
    assert_string_equal(s, "interpolation");
    assert_int_equal(lf_options_get_string(o, "interpolation.sed_model", &s), LF_OK);
    assert_string_equal(s, "");
}

/* The named presets hold the values lidarflow.h documents, keep "threads", and a key set after
 * the preset overrides it. */
static void test_named_presets(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    lf_options_t *fresh = NULL;
    assert_int_equal(lf_options_create(&fresh), LF_OK);
    assert_int_equal(lf_options_set_int(o, "threads", 4), LF_OK);
    const char *s = NULL;

    assert_int_equal(lf_options_set_string(o, "preset", "fast"), LF_OK);
    assert_int_equal(lf_options_get_string(o, "preset", &s), LF_OK);
    assert_string_equal(s, "fast");
    assert_true(get_number(o, "threads") == 4.0);
    const char *m = NULL;
    assert_int_equal(lf_options_get_string(o, "matching.method", &m), LF_OK);
    assert_string_equal(m, "decoupled");
    assert_true(get_number(o, "matching.flow_patch_size") == 6.0);
    assert_true(get_number(o, "matching.flow_patch_stride") == 3.0); /* default's is 2 */
    assert_true(get_number(fresh, "matching.flow_patch_stride") == 2.0);
    assert_true(get_number(o, "matching.flow_backward_patch_stride") == 0.0); /* the forward's */
    assert_true(get_number(o, "stereo.ternary_census") == 1.0); /* default's is binary */
    assert_true(get_number(o, "stereo.census_threshold") == 1.0);
    assert_true(get_number(fresh, "stereo.ternary_census") == 0.0);
    assert_true(get_number(fresh, "stereo.census_threshold") == 0.0);
    assert_true(get_number(o, "matching.flow_prior_track_step") == 12.0);
    assert_true(get_number(o, "matching.min_coarsest_height") == get_number(fresh, "matching.min_coarsest_height"));
    assert_true(fabs(get_number(o, "processing_scale") - 0.65) < 1e-12);
    assert_true(get_number(o, "matching.thin_from_level") == get_number(fresh, "matching.thin_from_level"));
    assert_true(get_number(o, "matching.flow_patch_size") == get_number(fresh, "matching.flow_patch_size"));

    /* paper: the paper's design (PatchMatch stage 1 at full size), not the default's. */
    assert_int_equal(lf_options_set_string(o, "preset", "paper"), LF_OK);
    assert_int_equal(lf_options_get_string(o, "matching.method", &m), LF_OK);
    assert_string_equal(m, "patchmatch");
    assert_true(get_number(o, "processing_scale") == 1.0);
    assert_true(get_number(o, "matching.guided_stereo") == 0.0);
    assert_true(get_number(o, "matching.flow_patch_size") != get_number(fresh, "matching.flow_patch_size"));
    assert_true(get_number(o, "threads") == 4.0);

    assert_int_equal(lf_options_set_int(o, "matching.iterations", 5), LF_OK); /* after the preset */
    assert_true(get_number(o, "matching.iterations") == 5.0);

    assert_int_equal(lf_options_set_string(o, "preset", "balanced"), LF_OK);
    assert_true(get_number(o, "matching.thin_from_level") == 1.0);
    assert_true(get_number(o, "matching.backward_grid_step") == 6.0);
    assert_true(get_number(o, "consistency.fb_search_radius") == 2.0);
    assert_true(get_number(o, "matching.iterations") == get_number(fresh, "matching.iterations"));
    assert_true(get_number(o, "processing_scale") == 1.0);
    assert_true(get_number(o, "matching.thin_from_level") != get_number(fresh, "matching.thin_from_level"));

    /* realtime: the decoupled stage 1 (a string key of its own), at a reduced size. */
    assert_int_equal(lf_options_set_string(o, "preset", "realtime"), LF_OK);
    const char *method = NULL;
    assert_int_equal(lf_options_get_string(o, "matching.method", &method), LF_OK);
    assert_string_equal(method, "decoupled");
    assert_true(get_number(o, "processing_scale") < 1.0);
    assert_true(get_number(o, "matching.flow_backward_patch_stride") == 4.0); /* coarser than the forward's 3 */
    assert_int_equal(lf_options_set_string(o, "matching.method", "patchmatch"), LF_OK);
    assert_int_equal(lf_options_get_string(o, "matching.method", &method), LF_OK);
    assert_string_equal(method, "patchmatch");
    assert_int_equal(lf_options_set_string(o, "matching.method", "sgm"), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_get_string(o, "matching.method", &method), LF_OK);
    assert_string_equal(method, "patchmatch"); /* a refused value changes nothing */

    /* An estimator accepts every preset. */
    static const char *names[] = {"default", "paper", "balanced", "fast", "realtime"};
    lf_calibration_t cal;
    lf_calibration_init(&cal);
    cal.fx = cal.fy = 700;
    cal.cx = 320;
    cal.cy = 240;
    cal.baseline = 0.5;
    for (int i = 0; i < 5; ++i) {
        assert_int_equal(lf_options_set_string(o, "preset", names[i]), LF_OK);
        lf_estimator_t *h = NULL;
        assert_int_equal(lf_create(o, &cal, &h), LF_OK);
        lf_destroy(h);
    }

    /* Unknown names list the known ones. */
    assert_int_equal(lf_options_set_string(o, "preset", "Fast"), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "balanced"));
    assert_int_equal(lf_options_get_string(o, "preset", &s), LF_OK);
    assert_string_equal(s, "realtime");
    lf_options_destroy(fresh);
}

static void test_unknown_keys_and_nulls(void **state) {
    lf_options_t *o = (lf_options_t *)*state;
    assert_int_equal(lf_options_set_int(o, "thread", 2), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "unknown option key 'thread'"));
    assert_int_equal(lf_options_set_float(o, "", 1.0), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_set_string(o, "nope", "x"), LF_ERR_INVALID_ARGUMENT);
    double d;
    assert_int_equal(lf_options_get_float(o, "nope", &d), LF_ERR_INVALID_ARGUMENT);

    assert_int_equal(lf_options_set_int(o, NULL, 1), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "key is NULL"));
    assert_int_equal(lf_options_set_string(o, "preset", NULL), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_options_last_error(o), "value is NULL"));
    assert_int_equal(lf_options_get_int(o, "threads", NULL), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_get_float(o, "threads", NULL), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_get_string(o, "preset", NULL), LF_ERR_INVALID_ARGUMENT);

    /* Without an object the message goes to the thread's lf_last_error(NULL). */
    assert_int_equal(lf_options_set_int(NULL, "threads", 2), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_last_error(NULL), "options is NULL"));
    assert_ptr_equal(lf_options_last_error(NULL), lf_last_error(NULL));
    assert_int_equal(lf_options_set_float(NULL, "threads", 2), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_set_string(NULL, "preset", "default"), LF_ERR_INVALID_ARGUMENT);
    int64_t i;
    const char *s;
    assert_int_equal(lf_options_get_int(NULL, "threads", &i), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_get_float(NULL, "threads", &d), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_get_string(NULL, "preset", &s), LF_ERR_INVALID_ARGUMENT);
    assert_int_equal(lf_options_create(NULL), LF_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(lf_last_error(NULL), "out is NULL"));
    lf_options_destroy(NULL);

    /* The object still works, and a success clears its message. */
    assert_int_equal(lf_options_set_int(o, "threads", 2), LF_OK);
    assert_string_equal(lf_options_last_error(o), "");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_defaults_match_documentation, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bounds_of_every_key, setup, teardown),
        cmocka_unit_test_setup_teardown(test_float_keys_accept_integers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_support_window_sets_both_stages, setup, teardown),
        cmocka_unit_test_setup_teardown(test_string_keys, setup, teardown),
        cmocka_unit_test_setup_teardown(test_preset_resets_all_but_threads, setup, teardown),
        cmocka_unit_test_setup_teardown(test_named_presets, setup, teardown),
        cmocka_unit_test_setup_teardown(test_unknown_keys_and_nulls, setup, teardown),
    };
    return cmocka_run_group_tests_name("capi_options", tests, NULL, NULL);
}
