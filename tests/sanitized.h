/* SPDX-License-Identifier: MIT */
#pragma once
/* LF_TEST_SANITIZED: defined (1) when the test is built with AddressSanitizer, ThreadSanitizer
 * or MemorySanitizer, by gcc (its macros) or clang (its feature tests). Their allocators reserve
 * address space and keep freed blocks resident, so tests of address-space limits and of
 * resident memory skip under them. C and C++: for the suites that see only the public headers
 * (the C ABI's, the bridge's); the core's suites ask core/sanitizers.hpp, as the core does. */
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LF_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define LF_TEST_SANITIZED 1
#endif
#endif
