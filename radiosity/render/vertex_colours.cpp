// Area-weighted averaging of patch radiosity at shared vertex positions; see vertex_colours.hpp.
#include "radiosity/render/vertex_colours.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace radiosity {
namespace {

const double kPi = 3.14159265358979323846;

// A vertex position rounded to a grid of step `cell`. Patches cut from the same triangle share bit-identical
// vertices; those from different entities may differ in the last bits after transforms, and rounding merges them.
// Two copies of one point straddle a rounding boundary only with probability (their distance / cell) ~ 1e-7,
// which is why the tolerance is a grid and not a neighbour search.
struct Key {
  std::int64_t x, y, z;
  bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
};

struct KeyHash {
  size_t operator()(const Key& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(k.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return static_cast<size_t>(h);
  }
};

// The patches that blend into each corner: body(i, k, js) for corner k of patch i, js the patches j (with their
// areas) that share its position and face within the crease, in a fixed order. Shared by the colours and the weights.
template <class Body>
void for_each_corner(const Mesh& m, double crease_deg, bool parallel, Body&& body) {
  const size_t n = m.size();
  if (n == 0) return;

  // Rounding noise scales with the size of the coordinates, and so does the grid; it also keeps v / cell <= 1e9.
  double scale = 0;
  for (const Patch& p : m.patches)
    for (const Vec3& v : p.v) scale = std::max({scale, std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  const double cell = std::max(scale, 1e-300) * 1e-9;
  auto key = [cell](const Vec3& v) {
    return Key{std::llround(v.x / cell), std::llround(v.y / cell), std::llround(v.z / cell)};
  };

  std::vector<Vec3> normal(n);
  std::vector<double> area(n);
  std::unordered_map<Key, std::vector<size_t>, KeyHash> by_position;  // position -> the patches with a vertex there
  by_position.reserve(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const Patch& p = m.patches[i];
    area[i] = p.area();
    normal[i] = area[i] > 0 ? p.normal() : Vec3{};  // a degenerate patch has no direction and no weight
    for (const Vec3& v : p.v) {
      std::vector<size_t>& list = by_position[key(v)];
      if (list.empty() || list.back() != i) list.push_back(i);  // a patch counts once even if two corners merge
    }
  }

  const double cos_crease = std::cos(std::clamp(crease_deg, 0.0, 180.0) * kPi / 180);
  auto corner = [&](size_t i, std::vector<std::pair<size_t, double>>& js) {
    for (int k = 0; k < 3; ++k) {
      js.clear();
      for (size_t j : by_position.at(key(m.patches[i].v[k]))) {
        // The 1e-12 lets a patch blend with itself and its coplanar neighbours at crease_deg = 0.
        if (normal[i].dot(normal[j]) < cos_crease - 1e-12) continue;
        js.emplace_back(j, area[j]);
      }
      body(i, k, js);
    }
  };
  if (parallel) {
#pragma omp parallel
    {
      std::vector<std::pair<size_t, double>> js;
#pragma omp for schedule(static)
      for (size_t i = 0; i < n; ++i) corner(i, js);
    }
  } else {
    std::vector<std::pair<size_t, double>> js;
    for (size_t i = 0; i < n; ++i) corner(i, js);
  }
}

}  // namespace

std::vector<std::array<Rgb, 3>> smooth_vertex_colours(const Mesh& m, const std::vector<Rgb>& radiosity,
                                                      double crease_deg) {
  std::vector<std::array<Rgb, 3>> out(m.size());
  for_each_corner(m, crease_deg, true, [&](size_t i, int k, const std::vector<std::pair<size_t, double>>& js) {
    Rgb sum{0, 0, 0};
    double weight = 0;
    for (const auto& [j, a] : js) {
      for (int c = 0; c < 3; ++c) sum[c] += a * radiosity[j][c];
      weight += a;
    }
    for (int c = 0; c < 3; ++c) out[i][k][c] = weight > 0 ? sum[c] / weight : radiosity[i][c];
  });
  return out;
}

VertexWeights smooth_vertex_weights(const Mesh& m, double crease_deg) {
  VertexWeights w;
  w.start.push_back(0);
  for_each_corner(m, crease_deg, false, [&](size_t i, int, const std::vector<std::pair<size_t, double>>& js) {
    double total = 0;
    for (const auto& [j, a] : js) total += a;
    if (total > 0) {
      for (const auto& [j, a] : js) {
        w.patch.push_back(uint32_t(j));
        w.weight.push_back(float(a / total));
      }
    } else {
      w.patch.push_back(uint32_t(i));
      w.weight.push_back(1.0f);
    }
    w.start.push_back(uint32_t(w.patch.size()));
  });
  return w;
}

}  // namespace radiosity
