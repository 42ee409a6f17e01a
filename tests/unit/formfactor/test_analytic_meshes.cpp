// The analytic meshes have the geometry their closed forms assume: sizes, areas, orientation, and a cube that is
// closed (every edge shared by exactly two faces, in opposite directions).
#include <gtest/gtest.h>

#include <map>
#include <tuple>

#include "common/errors.hpp"
#include "radiosity/scene/analytic.hpp"
#include "tests/unit/formfactor/references.hpp"

using namespace radiosity;
using fftest::entity_area;

TEST(AnalyticMeshes, FacingSquares) {
  const Mesh m = two_facing_squares(3);
  ASSERT_EQ(m.size(), 36u);
  ASSERT_EQ(m.entities, (std::vector<std::string>{"square1", "square2"}));
  EXPECT_NEAR(entity_area(m, 0), 1.0, 1e-12);
  EXPECT_NEAR(entity_area(m, 1), 1.0, 1e-12);
  for (const Patch& p : m.patches) {
    const Vec3 n = p.normal();
    EXPECT_NEAR(n.z, p.entity == 0 ? 1.0 : -1.0, 1e-12);  // they face each other
    EXPECT_NEAR(p.area(), 1.0 / 18, 1e-12);
  }
}

TEST(AnalyticMeshes, PerpendicularSquares) {
  const Mesh m = perpendicular_squares(2);
  ASSERT_EQ(m.size(), 16u);
  EXPECT_NEAR(entity_area(m, 0), 1.0, 1e-12);
  EXPECT_NEAR(entity_area(m, 1), 1.0, 1e-12);
  for (const Patch& p : m.patches) {
    const Vec3 n = p.normal();
    EXPECT_NEAR(p.entity == 0 ? n.z : n.x, 1.0, 1e-12);
    for (const Vec3& v : p.v) EXPECT_TRUE(v.x >= 0 && v.z >= 0);  // each square in front of the other
  }
}

TEST(AnalyticMeshes, CoaxialDisks) {
  const int rings = 3, segments = 16;
  const Mesh m = coaxial_disks(rings, segments);
  ASSERT_EQ(m.size(), size_t(2 * segments * (2 * rings - 1)));
  const double polygon = 0.5 * segments * std::sin(2 * M_PI / segments);  // inscribed regular polygon
  EXPECT_NEAR(entity_area(m, 0), polygon, 1e-12);
  EXPECT_NEAR(entity_area(m, 1), polygon, 1e-12);
  for (const Patch& p : m.patches) {
    EXPECT_NEAR(p.normal().z, p.entity == 0 ? 1.0 : -1.0, 1e-12);
    for (const Vec3& v : p.v) EXPECT_LE(std::hypot(v.x, v.y), 1.0 + 1e-12);
  }
}

TEST(AnalyticMeshes, CubeIsClosedWithFacesInward) {
  const Rgb rho{0.1, 0.2, 0.3}, e{1, 2, 3};
  const Mesh m = closed_unit_cube(3, rho, e);
  ASSERT_EQ(m.size(), 6u * 18);
  ASSERT_EQ(m.entities.size(), 6u);
  std::map<std::tuple<double, double, double, double, double, double>, int> directed;
  for (const Patch& p : m.patches) {
    EXPECT_EQ(p.reflectivity, rho);
    EXPECT_EQ(p.emission, e);
    const Vec3 to_centre = Vec3{0.5, 0.5, 0.5} - p.centroid();
    EXPECT_NEAR(p.normal().dot(to_centre), 0.5, 1e-12);  // inward, and the face is at distance 0.5
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = p.v[k], b = p.v[(k + 1) % 3];
      ++directed[{a.x, a.y, a.z, b.x, b.y, b.z}];
    }
  }
  // Closed and consistently oriented: every directed edge once, and its reverse once.
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1);
    const auto& [ax, ay, az, bx, by, bz] = edge;
    EXPECT_EQ(directed.count({bx, by, bz, ax, ay, az}), 1u);
  }
}

TEST(AnalyticMeshes, RejectsEmptySubdivisions) {
  EXPECT_THROW(two_facing_squares(0), hpcgi::UsageError);
  EXPECT_THROW(closed_unit_cube(-1, {0, 0, 0}, {0, 0, 0}), hpcgi::UsageError);
  EXPECT_THROW(coaxial_disks(2, 2), hpcgi::UsageError);
}
