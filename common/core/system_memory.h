// The machine's memory, for budgets: the coordinator's job films, a worker's registration and
// the film of a local render; and this process's own.
#pragma once

#include <cstdint>
#include <string>

namespace alphorn {

// Physical memory in bytes (not what is free: a budget must not change with the page cache).
uint64_t physicalMemoryBytes();

// This process's resident memory in bytes (0 where /proc cannot tell).
uint64_t residentMemoryBytes();

// Gives the memory the C library holds free back to the system (glibc keeps freed memory in
// its per-thread arenas, so a process that freed a large scene still looks as large as with
// it).
void returnFreeMemoryToSystem();

// "23.5 GiB", "512 MiB", "12 KiB", "100 bytes": a size for messages.
std::string formatBytes(uint64_t bytes);

}  // namespace alphorn
