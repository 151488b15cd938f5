#include "common/core/huge_page_allocator.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace alphorn {
namespace {

// The VmFlags line of the mapping of /proc/self/smaps that holds `address` ("" if none does).
std::string vmFlagsAt(const void* address) {
    const auto at = reinterpret_cast<uintptr_t>(address);
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    bool inside = false;
    while (std::getline(smaps, line)) {
        uintptr_t begin = 0, end = 0;
        char dash = 0;
        std::istringstream header(line);
        if (header >> std::hex >> begin >> dash >> end && dash == '-') {
            inside = begin <= at && at < end;
            continue;
        }
        if (inside && line.rfind("VmFlags:", 0) == 0) return line;
    }
    return "";
}

bool kernelHasTransparentHugePages() {
    return std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good();
}

TEST(HugePageAllocator, LargeBuffersAreAlignedToHugePagesAndAdvised) {
    std::vector<uint64_t, HugePageAllocator<uint64_t>> large(huge_pages::kMinBytes / 8, 7);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(large.data()) % huge_pages::kPageBytes, 0u);
    EXPECT_EQ(large.front() + large.back(), 14u);
    if (!kernelHasTransparentHugePages()) GTEST_SKIP() << "this kernel has no huge pages";
    // "hg": the mapping carries MADV_HUGEPAGE advice.
    EXPECT_NE(vmFlagsAt(large.data()).find(" hg"), std::string::npos) << vmFlagsAt(large.data());
}

TEST(HugePageAllocator, SmallBuffersUseTheOrdinaryHeap) {
    std::vector<uint64_t, HugePageAllocator<uint64_t>> small(huge_pages::kMinBytes / 8 - 1, 7);
    // The ordinary heap aligns to 16 bytes; a 2 MiB-aligned small buffer would mean it was
    // rounded up to huge pages.
    EXPECT_NE(reinterpret_cast<uintptr_t>(small.data()) % huge_pages::kPageBytes, 0u);
    if (!kernelHasTransparentHugePages()) GTEST_SKIP() << "this kernel has no huge pages";
    EXPECT_EQ(vmFlagsAt(small.data()).find(" hg"), std::string::npos) << vmFlagsAt(small.data());
}

TEST(HugePageAllocator, AbsurdSizesThrowInsteadOfWrapping) {
    HugePageAllocator<uint64_t> allocator;
    EXPECT_THROW(allocator.allocate(size_t(-1) / 4), std::bad_array_new_length);
}

}  // namespace
}  // namespace alphorn
