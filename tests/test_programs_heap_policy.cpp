// SPDX-License-Identifier: MIT
// The heap policy of the project's programs (src/programs/heap_policy.hpp): applied under glibc,
// and never over a GLIBC_TUNABLES malloc setting the user chose.
#include <cstdlib>
#include <cstring>

#include "programs/heap_policy.hpp"
#include "core/sanitizers.hpp"
#include "test_support.hpp"

namespace {

void user_tunables_win(void **) {
    setenv("GLIBC_TUNABLES", "glibc.malloc.trim_threshold=1048576", 1);
    const lidarflow::tools::HeapPolicy p = lidarflow::tools::apply_heap_policy();
    assert_false(p.applied);
    assert_string_equal(p.describe(), "glibc defaults");
    unsetenv("GLIBC_TUNABLES");
}

void applied_under_glibc(void **) {
    // Tunables of other glibc parts are not the allocator's: the policy still applies.
    setenv("GLIBC_TUNABLES", "glibc.cpu.hwcaps=-AVX512F", 1);
    const lidarflow::tools::HeapPolicy p = lidarflow::tools::apply_heap_policy();
    unsetenv("GLIBC_TUNABLES");
#if defined(__GLIBC__)
    if (!LIDARFLOW_SANITIZED) {  // the sanitizers' allocators ignore mallopt()
        assert_true(p.applied);
        assert_non_null(std::strstr(p.describe(), "keep"));
    }
#else
    assert_false(p.applied);
#endif
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(user_tunables_win),
        cmocka_unit_test(applied_under_glibc),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
