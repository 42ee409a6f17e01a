// Refuse what will not fit: estimate a run's memory before allocating and stop with a clear line instead of a
// std::bad_alloc or the OOM killer.
#pragma once
#include <cstddef>
#include <memory>
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

// Memory for a large array: one anonymous mapping (mmap), 2 MiB-aligned, given back by munmap. Its pages are zero
// and not yet touched: the caller's first write (a first-touch loop in the kernels' schedule) faults them in on the
// thread that will use them. It is asked for transparent huge pages (madvise MADV_HUGEPAGE: 512 times fewer page
// faults; quietly 4 KiB pages where the kernel has none, or with HPCGI_HUGE_PAGES=0 in the environment). Measured
// on a quiet 2-core Intel Xeon VM (THP "madvise"), three alternating runs each: the setup of --method fmg at
// N = 8192 took 0.14-0.20 s with them against 0.30-0.32 s without, its solve 1.10-1.17 s against 1.14-1.18 s; the
// setup of --precond mg at N = 6000 0.27-0.29 s against 0.45-0.48 s, its solve 4% slower. (On the AMD EPYC VM
// of the reference, loaded, they once made that setup slower: HPCGI_HUGE_PAGES=0 is the way back.)
// Throws std::bad_alloc when the mapping fails (require_host_memory refuses before, with a clear line).
void* huge_alloc(std::size_t bytes);
void huge_free(void* p, std::size_t bytes) noexcept;

struct HugeFree {
  std::size_t bytes = 0;
  void operator()(void* p) const noexcept { huge_free(p, bytes); }
};
template <class T>
using HugeArray = std::unique_ptr<T[], HugeFree>;

// n values of T in huge_alloc's memory (not constructed: for arithmetic types, which the caller writes first).
template <class T>
HugeArray<T> huge_array(std::size_t n) {
  const std::size_t bytes = (n > 0 ? n : 1) * sizeof(T);
  return HugeArray<T>(static_cast<T*>(huge_alloc(bytes)), HugeFree{bytes});
}

}  // namespace hpcgi
