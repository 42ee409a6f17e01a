// What the relighting's unit tests share: a seeded generator and the max-norm relative difference.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity::test {

inline uint64_t lcg(uint64_t& s) { return s = s * 6364136223846793005ull + 1442695040888963407ull; }
inline double uniform(uint64_t& s) { return double(lcg(s) >> 11) * 0x1.0p-53; }

// max |a - b| over max |b|, every channel of every patch.
inline double rel_diff(const std::vector<Rgb>& a, const std::vector<Rgb>& b) {
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      num = std::max(num, std::abs(a[i][c] - b[i][c]));
      den = std::max(den, std::abs(b[i][c]));
    }
  return num / den;
}

}  // namespace radiosity::test
