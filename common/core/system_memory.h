// The machine's memory, for budgets: the coordinator's job films, a worker's registration and
// the film of a local render.
#pragma once

#include <cstdint>
#include <string>

namespace alphorn {

// Physical memory in bytes (not what is free: a budget must not change with the page cache).
uint64_t physicalMemoryBytes();

// "23.5 GiB", "512 MiB", "12 KiB", "100 bytes": a size for messages.
std::string formatBytes(uint64_t bytes);

}  // namespace alphorn
