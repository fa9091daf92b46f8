// SPDX-License-Identifier: MIT
#pragma once
// std::allocator replacement for the large descriptor images.
//
// Why: the matcher reads descriptors at scattered positions of four images of ~60 MB each
// (KITTI, 128 bytes per pixel); with 4 KiB pages nearly every sample misses the TLB. Blocks of
// at least 4 MiB are therefore 2 MiB-aligned and marked MADV_HUGEPAGE, so that the kernel can
// back them with transparent huge pages (where THP is off this is only an alignment).
//
// They are mapped and unmapped directly (Linux, no sanitizer) rather than taken from malloc:
// glibc raises its mmap threshold to the size of each mapped block it frees (up to 32 MiB), so
// from the second frame on the coarse levels (~15 MB each) came from the heap, and the heap kept
// their pages after free(): peak RSS of `bench_pipeline --runs 3` grew from run to run. Unmapped
// blocks go back to the system at once. Under ASan/TSan malloc is kept, so that the sanitizers
// still see overruns of these buffers. Smaller blocks come from malloc.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "core/sanitizers.hpp"

// The sanitizers track malloc'd blocks only: under them the large blocks stay on malloc.
#define LIDARFLOW_HUGE_PAGE_ALLOC_USES_MALLOC LIDARFLOW_SANITIZED

namespace lidarflow::features {

template <class T>
struct HugePageAllocator {
    using value_type = T;

    HugePageAllocator() noexcept = default;
    template <class U>
    HugePageAllocator(const HugePageAllocator<U> &) noexcept {}

    // Throws std::bad_alloc when out of memory; the block is released by deallocate().
    T *allocate(std::size_t n) {
        if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_alloc();
        const std::size_t bytes = n * sizeof(T);
        void *p = is_large(bytes) ? map_huge(rounded(bytes)) : std::malloc(bytes == 0 ? 1 : bytes);
        if (!p) throw std::bad_alloc();
        return static_cast<T *>(p);
    }
    // n must be the count given to allocate() (the std::allocator contract).
    void deallocate(T *p, std::size_t n) noexcept {
        if (is_large(n * sizeof(T)))
            unmap_huge(p, rounded(n * sizeof(T)));
        else
            std::free(p);
    }
    // resize() leaves new elements default-initialised (uninitialised bytes): every user writes
    // the whole image right after, and zero-filling ~60 MB per image first was a measurable pass.
    template <class U>
    void construct(U *p) noexcept(std::is_nothrow_default_constructible_v<U>) {
        ::new (static_cast<void *>(p)) U;
    }
    template <class U, class... Args>
    void construct(U *p, Args &&...args) {
        ::new (static_cast<void *>(p)) U(std::forward<Args>(args)...);
    }

private:
    static constexpr std::size_t kHuge = std::size_t(2) << 20;
    static bool is_large(std::size_t bytes) { return bytes >= 2 * kHuge; }
    static std::size_t rounded(std::size_t bytes) { return (bytes + kHuge - 1) / kHuge * kHuge; }

#if defined(__linux__) && !LIDARFLOW_HUGE_PAGE_ALLOC_USES_MALLOC
    // Maps size + 2 MiB and unmaps the unaligned head and the tail: mmap only promises 4 KiB.
    static void *map_huge(std::size_t size) {
        if (size > static_cast<std::size_t>(-1) - kHuge) return nullptr;
        void *raw = mmap(nullptr, size + kHuge, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED) return nullptr;
        const auto begin = reinterpret_cast<std::uintptr_t>(raw);
        const std::uintptr_t aligned = (begin + kHuge - 1) & ~(std::uintptr_t(kHuge) - 1);
        if (aligned > begin) munmap(raw, aligned - begin);
        const std::uintptr_t tail = aligned + size, end = begin + size + kHuge;
        if (end > tail) munmap(reinterpret_cast<void *>(tail), end - tail);
        void *p = reinterpret_cast<void *>(aligned);
#if defined(MADV_HUGEPAGE)
        madvise(p, size, MADV_HUGEPAGE);  // advisory: failure only costs speed
#endif
        return p;
    }
    static void unmap_huge(void *p, std::size_t size) noexcept { munmap(p, size); }
#else
    static void *map_huge(std::size_t size) {
        void *p = std::aligned_alloc(kHuge, size);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        if (p) madvise(p, size, MADV_HUGEPAGE);  // advisory: failure only costs speed
#endif
        return p;
    }
    static void unmap_huge(void *p, std::size_t) noexcept { std::free(p); }
#endif

public:
    template <class U>
    bool operator==(const HugePageAllocator<U> &) const noexcept { return true; }
    template <class U>
    bool operator!=(const HugePageAllocator<U> &) const noexcept { return false; }
};

}  // namespace lidarflow::features
