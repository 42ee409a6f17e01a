// A finer mesh's radiosity carried onto a coarser mesh of the same scene (mesh_map.hpp).
#include <gtest/gtest.h>

#include "common/errors.hpp"
#include "radiosity/solve/mesh_map.hpp"

using namespace radiosity;

namespace {

// Triangle t split in four at its midpoints (subdivide.hpp's pieces), `levels` times.
std::vector<Patch> split(const Patch& t, int levels) {
  if (levels == 0) return {t};
  const auto& v = t.v;
  const Vec3 m01 = (v[0] + v[1]) * 0.5, m12 = (v[1] + v[2]) * 0.5, m20 = (v[2] + v[0]) * 0.5;
  std::vector<Patch> out;
  for (const std::array<Vec3, 3>& piece : {std::array<Vec3, 3>{v[0], m01, m20}, std::array<Vec3, 3>{v[1], m12, m01},
                                           std::array<Vec3, 3>{v[2], m20, m12}, std::array<Vec3, 3>{m12, m20, m01}}) {
    Patch q = t;
    q.v = piece;
    for (const Patch& r : split(q, levels - 1)) out.push_back(r);
  }
  return out;
}

// Two entities: a unit square (two triangles) in z = 0 and a skewed triangle in the plane x = 2.
Mesh coarse_mesh() {
  Mesh m;
  m.entities = {"square", "wall"};
  auto add = [&](Vec3 a, Vec3 b, Vec3 c, int entity) {
    Patch p;
    p.v = {a, b, c};
    p.entity = entity;
    m.patches.push_back(p);
  };
  add({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, 0);
  add({0, 0, 0}, {1, 1, 0}, {0, 1, 0}, 0);
  add({2, 0, 0}, {2, 3, 0.5}, {2, 0.2, 2}, 1);
  return m;
}

Mesh refined(const Mesh& coarse, int levels) {
  Mesh m;
  m.entities = coarse.entities;
  for (const Patch& p : coarse.patches)
    for (const Patch& q : split(p, levels)) m.patches.push_back(q);
  return m;
}

}  // namespace

TEST(MeshMap, AreaWeightedMeanOfALinearFunctionIsItsValueAtTheCentroid) {
  const Mesh coarse = coarse_mesh(), fine = refined(coarse, 3);
  ASSERT_EQ(fine.size(), 3u * 64);
  // B = 1 + x + 2y - z per channel: the area-weighted mean over a triangle is its value at the centroid.
  auto f = [](const Vec3& p) { return 1 + p.x + 2 * p.y - p.z; };
  std::vector<Rgb> B;
  for (const Patch& p : fine.patches) B.push_back({f(p.centroid()), 2 * f(p.centroid()), 0});
  const std::vector<Rgb> onto = area_weighted_onto(coarse, fine, B);
  for (size_t I = 0; I < coarse.size(); ++I) {
    EXPECT_NEAR(onto[I][0], f(coarse.patches[I].centroid()), 1e-12);
    EXPECT_NEAR(onto[I][1], 2 * f(coarse.patches[I].centroid()), 1e-12);
    EXPECT_EQ(onto[I][2], 0);
  }
  for (const Rgb& b : area_weighted_onto(coarse, coarse, std::vector<Rgb>(3, Rgb{1, 2, 3})))
    for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(b[c], c + 1.0);
}

TEST(MeshMap, AMeshThatIsNoRefinementIsRefused) {
  const Mesh coarse = coarse_mesh();
  Mesh moved = refined(coarse, 1);
  moved.patches[5].v[0].z += 0.1;  // off its parent's plane
  EXPECT_THROW(containing_patches(coarse, moved), hpcgi::UsageError);
  Mesh missing = refined(coarse, 1);
  missing.patches.pop_back();  // the last coarse patch is not covered
  EXPECT_THROW(containing_patches(coarse, missing), hpcgi::UsageError);
}
