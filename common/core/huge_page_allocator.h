// An allocator for large buffers (image-sized films) that asks Linux for transparent huge pages.
//
// A film of a 512 x 512 image with its odd passes' sums is 32 MiB. Allocated the ordinary way,
// its first touch takes a page fault per 4 KiB page; in a virtual machine a fault costs ~12 us,
// so zeroing that film took ~100 ms, serially, before a render's first sample (6% of an 8-pass
// Cornell box render on two threads; bench/RESULTS.md). Backed by 2 MiB pages (madvise
// MADV_HUGEPAGE, which takes effect under the kernel's default "madvise" policy) the same film
// takes ~4 ms. Buffers below kMinBytes keep the ordinary allocator: rounding them up to whole
// huge pages would waste memory for no measurable gain.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <vector>

namespace alphorn {

namespace huge_pages {

inline constexpr size_t kPageBytes = size_t(2) << 20;
inline constexpr size_t kMinBytes = size_t(4) << 20;

// Memory for `bytes` (>= kMinBytes) aligned to kPageBytes and advised to use huge pages; throws
// std::bad_alloc when out of memory.
void* allocate(size_t bytes);
void release(void* memory);

}  // namespace huge_pages

template <typename T>
struct HugePageAllocator {
    using value_type = T;

    HugePageAllocator() = default;
    template <typename U>
    HugePageAllocator(const HugePageAllocator<U>&) {}

    T* allocate(size_t n) {
        if (n > size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
        const size_t bytes = n * sizeof(T);
        if (bytes < huge_pages::kMinBytes) return std::allocator<T>().allocate(n);
        return static_cast<T*>(huge_pages::allocate(bytes));
    }
    void deallocate(T* p, size_t n) {
        if (n * sizeof(T) < huge_pages::kMinBytes) return std::allocator<T>().deallocate(p, n);
        huge_pages::release(p);
    }

    template <typename U>
    bool operator==(const HugePageAllocator<U>&) const {
        return true;
    }
};

// A std::vector whose large buffers use huge pages (per-pass photon arrays of tens of MiB).
template <typename T>
using HugePageVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace alphorn
