// SPDX-License-Identifier: MIT
// The udpm receive buffer the bridge asks for (lcm_url.cpp): never more than net.core.rmem_max
// (LCM warns on more), the URL's other options kept, other providers untouched.
#include <string>

#include "lcm_url.hpp"

// cmocka 1.1 has no extern "C" guard of its own; included last because of its macros.
extern "C" {
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
}

using namespace lidarflow::bridge;

namespace {

void expect_url(const ReceiveBufferFit &fit, const char *url) { assert_string_equal(fit.url.c_str(), url); }

void test_capped_at_rmem_max(void **) {
    const ReceiveBufferFit fit = fit_receive_buffer("udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216", 4194304);
    expect_url(fit, "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304");
    assert_int_equal(fit.wanted, 16777216);
    assert_int_equal(fit.requested, 4194304);
    assert_true(fit.limited());
    // Option order kept; recv_buf_size first or in the middle.
    expect_url(fit_receive_buffer("udpm://239.255.76.67:7667?recv_buf_size=9000000&ttl=1", 1000000),
               "udpm://239.255.76.67:7667?ttl=1&recv_buf_size=1000000");
}

void test_within_limit_kept(void **) {
    const ReceiveBufferFit fit = fit_receive_buffer("udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152", 16777216);
    expect_url(fit, "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152");
    assert_false(fit.limited());
}

void test_added_when_missing(void **) {
    ReceiveBufferFit fit = fit_receive_buffer(kLcmDefaultUrl, 212992);
    expect_url(fit, "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=212992");
    assert_int_equal(fit.wanted, kWantedReceiveBuffer);
    assert_true(fit.limited());
    fit = fit_receive_buffer("udpm://239.255.76.67:7667", 33554432);
    expect_url(fit, "udpm://239.255.76.67:7667?recv_buf_size=16777216");
    assert_false(fit.limited());
}

void test_left_alone(void **) {
    // Other providers, an unknown limit, a value LCM itself refuses.
    for (const char *url : {"memq://", "file:///tmp/x.log?mode=w", "tcpq://localhost:7700"})
        expect_url(fit_receive_buffer(url, 4194304), url);
    expect_url(fit_receive_buffer("udpm://239.255.76.67:7667?recv_buf_size=16777216", -1),
               "udpm://239.255.76.67:7667?recv_buf_size=16777216");
    for (const char *url : {"udpm://239.255.76.67:7667?recv_buf_size=abc", "udpm://239.255.76.67:7667?recv_buf_size=",
                            "udpm://239.255.76.67:7667?recv_buf_size=0",
                            "udpm://239.255.76.67:7667?recv_buf_size=99999999999"}) {
        const ReceiveBufferFit fit = fit_receive_buffer(url, 4194304);
        expect_url(fit, url);
        assert_false(fit.limited());
    }
}

void test_effective_url(void **) {
    assert_string_equal(effective_lcm_url("memq://").c_str(), "memq://");
    setenv("LCM_DEFAULT_URL", "udpm://239.255.76.68:7668?ttl=0", 1);
    assert_string_equal(effective_lcm_url("").c_str(), "udpm://239.255.76.68:7668?ttl=0");
    setenv("LCM_DEFAULT_URL", "", 1);
    assert_string_equal(effective_lcm_url("").c_str(), kLcmDefaultUrl);
    unsetenv("LCM_DEFAULT_URL");
    assert_string_equal(effective_lcm_url("").c_str(), kLcmDefaultUrl);
}

}  // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_capped_at_rmem_max), cmocka_unit_test(test_within_limit_kept),
        cmocka_unit_test(test_added_when_missing), cmocka_unit_test(test_left_alone),
        cmocka_unit_test(test_effective_url),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
