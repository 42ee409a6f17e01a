// Refuse what will not fit: estimate a run's memory before allocating and stop with a clear line instead of a
// std::bad_alloc or the OOM killer.
#pragma once
#include <string>

namespace hpcgi {

// MemAvailable of /proc/meminfo in bytes (the physical memory size where that is missing).
double available_memory_bytes();

// Throws UsageError "WHO needs X GiB of memory, and this machine has Y GiB available" when bytes > available.
void require_host_memory(const std::string& who, double bytes);

// A size in bytes as a user writes it: "67108864", "64K", "64M", "1.5G", "2T", with or without "iB" or "B"
// ("64MiB", "64MB"), in binary units (K = 1024, M = 1024², ...), as Slurm's --mem counts. Throws UsageError for
// anything else, zero, a negative size or one that is not finite.
double parse_bytes(const std::string& text);

// "64.0 MiB", "1.50 GiB": a size for a message.
std::string format_bytes(double bytes);

}  // namespace hpcgi
