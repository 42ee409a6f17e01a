#include "radiosity/dist/split.hpp"

#include <stdexcept>

namespace radiosity::dist {

std::vector<size_t> split_by_work(const std::vector<uint64_t>& work, int parts) {
  if (parts < 1) throw std::invalid_argument("split_by_work: parts must be >= 1");
  const size_t n = work.size();
  unsigned __int128 total = 0;
  for (uint64_t w : work) total += w;
  std::vector<size_t> bounds(size_t(parts) + 1, n);
  bounds[0] = 0;
  // One pass: the running sum crosses the targets (r + 1)/parts · total in order; integer arithmetic (the sum
  // times parts against the target times total), so every rank computes the same bounds.
  unsigned __int128 before = 0;  // work of rows [0, i)
  size_t i = 0;
  for (int r = 0; r + 1 < parts; ++r) {
    const unsigned __int128 target = total * unsigned(r + 1);  // compared with before · parts
    while (i < n && before * unsigned(parts) < target) before += work[i++];
    bounds[size_t(r) + 1] = i;
  }
  return bounds;
}

}  // namespace radiosity::dist
