#include "common/memory.hpp"

#include <unistd.h>

#include <cstdio>
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

void require_host_memory(const std::string& who, double bytes) {
  const double avail = available_memory_bytes();
  if (bytes <= avail) return;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s needs %.2f GiB of memory, and this machine has %.2f GiB available",
                who.c_str(), bytes / (1 << 30), avail / (1 << 30));
  throw UsageError(buf);
}

}  // namespace hpcgi
