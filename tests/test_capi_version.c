/* SPDX-License-Identifier: MIT */
/* C ABI: status strings and version queries. Compiled as C99 against the public header only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "lidarflow/lidarflow.h"

static void test_version_matches_header(void **state) {
    (void)state;
    assert_int_equal(lf_version_number(), LF_VERSION_NUMBER);
    assert_string_equal(lf_version_string(), LF_VERSION_STRING);
    assert_int_equal(lf_abi_major(), LF_ABI_MAJOR);
}

static void test_status_strings(void **state) {
    (void)state;
    assert_string_equal(lf_status_string(LF_OK), "ok");
    for (int32_t s = LF_ERR_INVALID_ARGUMENT; s <= LF_ERR_INTERNAL; ++s) {
        const char *m = lf_status_string(s);
        assert_non_null(m);
        assert_true(strlen(m) > 0);
        assert_string_not_equal(m, "unknown status");
    }
    assert_string_equal(lf_status_string(-1), "unknown status");
    assert_string_equal(lf_status_string(9999), "unknown status");
}

static void test_status_values_are_stable(void **state) {
    (void)state;
    /* Numbering is ABI: these must never change. */
    assert_int_equal(LF_OK, 0);
    assert_int_equal(LF_ERR_INVALID_ARGUMENT, 1);
    assert_int_equal(LF_ERR_SIZE_MISMATCH, 2);
    assert_int_equal(LF_ERR_IO, 3);
    assert_int_equal(LF_ERR_FORMAT, 4);
    assert_int_equal(LF_ERR_BAD_STATE, 5);
    assert_int_equal(LF_ERR_NOT_READY, 6);
    assert_int_equal(LF_ERR_OUT_OF_MEMORY, 7);
    assert_int_equal(LF_ERR_INTERNAL, 8);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version_matches_header),
        cmocka_unit_test(test_status_strings),
        cmocka_unit_test(test_status_values_are_stable),
    };
    return cmocka_run_group_tests_name("capi_version", tests, NULL, NULL);
}
