#include "common/memory.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <new>

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/errors.hpp"

namespace hpcgi {

double available_memory_bytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kb = 0;
  std::string unit;
  while (in >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024.0;
  return static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGE_SIZE));
}

double parse_bytes(const std::string& text) {
  const std::string bad = "'" + text + "' is not a size in bytes (e.g. 67108864, 64M, 1.5G)";
  size_t pos = 0;
  double v = 0;
  try {
    v = std::stod(text, &pos);
  } catch (...) {
    throw UsageError(bad);
  }
  std::string unit = text.substr(pos);
  if (unit.size() == 3 && unit.compare(1, 2, "iB") == 0)
    unit.resize(1);
  else if (unit.size() == 2 && unit[1] == 'B')
    unit.resize(1);
  else if (unit == "B")
    unit.clear();
  double scale = 1;
  if (unit.size() > 1) throw UsageError(bad);
  if (unit.size() == 1) {
    const char* units = "KMGTP";
    const char* at = std::strchr(units, std::toupper(static_cast<unsigned char>(unit[0])));
    if (!at || unit[0] == 0) throw UsageError(bad);
    scale = std::ldexp(1.0, 10 * int(at - units + 1));
  }
  if (!std::isfinite(v) || v <= 0) throw UsageError(bad + ": it must be > 0");
  return v * scale;
}

std::string format_bytes(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
  int u = 0;
  while (u < 5 && std::fabs(bytes) >= 1024) {
    bytes /= 1024;
    ++u;
  }
  char buf[48];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", bytes, units[u]);
  return buf;
}

void require_host_memory(const std::string& who, double bytes) {
  const double avail = available_memory_bytes();
  if (bytes <= avail) return;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s needs %.2f GiB of memory, and this machine has %.2f GiB available",
                who.c_str(), bytes / (1 << 30), avail / (1 << 30));
  throw UsageError(buf);
}

namespace {
constexpr std::size_t kHugePage = std::size_t(2) << 20, kPage = 4096;
std::size_t whole_pages(std::size_t bytes) { return (bytes + kPage - 1) / kPage * kPage; }
}  // namespace

// The mapping is made 2 MiB larger, and its head and tail beyond a 2 MiB-aligned start are given back, so that
// the array's huge pages start where the array does.
void* huge_alloc(std::size_t bytes) {
  const std::size_t len = whole_pages(bytes);
  void* raw = mmap(nullptr, len + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  char* const lo = static_cast<char*>(raw);
  char* const hi = lo + len + kHugePage;
  char* const a = lo + (kHugePage - reinterpret_cast<std::uintptr_t>(lo) % kHugePage) % kHugePage;
  if (a > lo) munmap(lo, a - lo);
  if (hi > a + len) munmap(a + len, hi - (a + len));
#ifdef MADV_HUGEPAGE
  static const bool huge = [] {
    const char* e = std::getenv("HPCGI_HUGE_PAGES");
    return !(e && std::string(e) == "0");
  }();
  if (huge) madvise(a, len, MADV_HUGEPAGE);  // a kernel without THP answers EINVAL: 4 KiB pages, as without it
#endif
  return a;
}

void huge_free(void* p, std::size_t bytes) noexcept {
  if (p) munmap(p, whole_pages(bytes));
}

}  // namespace hpcgi
