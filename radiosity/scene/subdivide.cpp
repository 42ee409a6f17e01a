// Breadth-first midpoint subdivision; see subdivide.hpp.
#include "radiosity/scene/subdivide.hpp"

#include <deque>

namespace radiosity {

std::optional<std::vector<Patch>> subdivide(const std::vector<Patch>& triangles, double max_area,
                                            size_t max_patches) {
  std::deque<Patch> queue(triangles.begin(), triangles.end());
  std::vector<Patch> out;
  while (!queue.empty()) {
    if (out.size() + queue.size() > max_patches) return std::nullopt;
    Patch p = queue.front();
    queue.pop_front();
    if (p.area() <= max_area) {
      out.push_back(p);
      continue;
    }
    const auto& v = p.v;
    const Vec3 m01 = (v[0] + v[1]) * 0.5, m12 = (v[1] + v[2]) * 0.5, m20 = (v[2] + v[0]) * 0.5;
    for (const std::array<Vec3, 3>& piece : {std::array<Vec3, 3>{v[0], m01, m20}, std::array<Vec3, 3>{v[1], m12, m01},
                                             std::array<Vec3, 3>{v[2], m20, m12}, std::array<Vec3, 3>{m12, m20, m01}}) {
      Patch q = p;
      q.v = piece;
      queue.push_back(q);
    }
  }
  return out;
}

}  // namespace radiosity
