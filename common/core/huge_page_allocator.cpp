#include "common/core/huge_page_allocator.h"

#include <sys/mman.h>

#include <cstdlib>

namespace alphorn::huge_pages {

void* allocate(size_t bytes) {
    const size_t rounded = (bytes + kPageBytes - 1) / kPageBytes * kPageBytes;
    void* memory = std::aligned_alloc(kPageBytes, rounded);
    if (!memory) throw std::bad_alloc();
    // Advice only: on a kernel without transparent huge pages the buffer keeps 4 KiB pages.
    madvise(memory, rounded, MADV_HUGEPAGE);
    return memory;
}

void release(void* memory) {
    std::free(memory);
}

}  // namespace alphorn::huge_pages
