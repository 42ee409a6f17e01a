// Refuse what will not fit: estimate a run's memory before allocating and stop with a clear line instead of a
// std::bad_alloc or the OOM killer.
#pragma once
#include <string>

namespace hpcgi {

// MemAvailable of /proc/meminfo in bytes (the physical memory size where that is missing).
double available_memory_bytes();

// Throws UsageError "WHO needs X GiB of memory, and this machine has Y GiB available" when bytes > available.
void require_host_memory(const std::string& who, double bytes);

}  // namespace hpcgi
