// SPDX-License-Identifier: MIT
#pragma once
// std::allocator replacement for the large descriptor images.
//
// Why: the matcher reads descriptors at scattered positions of four images of ~60 MB each
// (KITTI, 128 bytes per pixel); with 4 KiB pages nearly every sample misses the TLB. Blocks of
// at least 4 MiB are therefore 2 MiB-aligned and marked MADV_HUGEPAGE, so that the kernel can
// back them with transparent huge pages (where THP is off this is only an alignment). Smaller
// blocks come from malloc as usual. free() releases both kinds.
#include <cstddef>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

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
        constexpr std::size_t kHuge = std::size_t(2) << 20;
        void *p = nullptr;
        if (bytes >= 2 * kHuge) {
            const std::size_t rounded = (bytes + kHuge - 1) / kHuge * kHuge;
            p = std::aligned_alloc(kHuge, rounded);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
            if (p) madvise(p, rounded, MADV_HUGEPAGE);  // advisory: failure only costs speed
#endif
        } else {
            p = std::malloc(bytes == 0 ? 1 : bytes);
        }
        if (!p) throw std::bad_alloc();
        return static_cast<T *>(p);
    }
    void deallocate(T *p, std::size_t) noexcept { std::free(p); }
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

    template <class U>
    bool operator==(const HugePageAllocator<U> &) const noexcept { return true; }
    template <class U>
    bool operator!=(const HugePageAllocator<U> &) const noexcept { return false; }
};

}  // namespace lidarflow::features
