// SPDX-License-Identifier: MIT
#pragma once
// LIDARFLOW_SANITIZED: 1 when built with AddressSanitizer or ThreadSanitizer (gcc or clang).
// Their allocators replace glibc's: they track malloc'd blocks only, ignore mallopt(), and abort
// on absurd sizes instead of throwing, so code and tests that depend on the allocator ask here.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LIDARFLOW_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define LIDARFLOW_SANITIZED 1
#endif
#endif
#ifndef LIDARFLOW_SANITIZED
#define LIDARFLOW_SANITIZED 0
#endif
