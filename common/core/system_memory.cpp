#include "common/core/system_memory.h"

#include <absl/strings/str_format.h>
#include <malloc.h>
#include <unistd.h>

#include <fstream>

namespace alphorn {

uint64_t physicalMemoryBytes() {
    return uint64_t(::sysconf(_SC_PHYS_PAGES)) * uint64_t(::sysconf(_SC_PAGE_SIZE));
}

uint64_t residentMemoryBytes() {
    // statm: total program size, then resident pages.
    std::ifstream statm("/proc/self/statm");
    uint64_t size = 0, resident = 0;
    if (!(statm >> size >> resident)) return 0;
    return resident * uint64_t(::sysconf(_SC_PAGE_SIZE));
}

void returnFreeMemoryToSystem() {
    ::malloc_trim(0);
}

std::string formatBytes(uint64_t bytes) {
    if (bytes >= (uint64_t(1) << 30)) return absl::StrFormat("%.1f GiB", double(bytes) / (1 << 30));
    if (bytes >= (uint64_t(1) << 20)) return absl::StrFormat("%.0f MiB", double(bytes) / (1 << 20));
    if (bytes >= (uint64_t(1) << 10)) return absl::StrFormat("%.0f KiB", double(bytes) / (1 << 10));
    return absl::StrFormat("%u bytes", bytes);
}

}  // namespace alphorn
