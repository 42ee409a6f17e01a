// The meaning of RRV's format, rule by rule from FORMAT.md: transforms (innermost first, components default 0,
// RRV's rotation, shear without effect), triangle strips, colour inheritance, subdivision and entities.
#include <gtest/gtest.h>

#include <cmath>

#include "radiosity/scene/rrv_reader.hpp"
#include "scene_test_util.hpp"

using radiosity::LoadOptions;
using radiosity::Mesh;
using radiosity::Vec3;

namespace {

// A scene whose objectdef "t" is the triangle (a, b, c) and whose body is `body`, loaded without subdivision.
Mesh with_triangle(const std::string& body, const Vec3& a = {0, 0, 0}, const Vec3& b = {1, 0, 0},
                   const Vec3& c = {0, 1, 0}) {
  auto vx = [](const Vec3& v) {
    return "<vertex x='" + std::to_string(v.x) + "' y='" + std::to_string(v.y) + "' z='" + std::to_string(v.z) + "'/>";
  };
  LoadOptions opt;
  opt.divide = 1e9;
  return radiosity::load_rrv_scene_string("<scene><head><objectdef name='t'><triangleset><triangle>" + vx(a) + vx(b) +
                                              vx(c) + "</triangle></triangleset></objectdef></head><body>" + body +
                                              "</body></scene>",
                                          opt);
}

void expect_vec(const Vec3& got, const Vec3& want) {
  EXPECT_NEAR(got.x, want.x, 1e-12);
  EXPECT_NEAR(got.y, want.y, 1e-12);
  EXPECT_NEAR(got.z, want.z, 1e-12);
}

Mesh strip(const std::string& children, const std::string& set_attributes = "", double divide = 1e9) {
  LoadOptions opt;
  opt.divide = divide;
  return radiosity::load_rrv_scene_string("<scene><head><objectdef name='s'><triangleset " + set_attributes + ">" +
                                              children +
                                              "</triangleset></objectdef></head>"
                                              "<body><object name='s'/></body></scene>",
                                          opt);
}

std::string v(int x, int y, int z) {
  return "<vertex x='" + std::to_string(x) + "' y='" + std::to_string(y) + "' z='" + std::to_string(z) + "'/>";
}

}  // namespace

TEST(Transforms, InnermostActsFirst) {
  // Vertex (1,0,0): scale by 2 then move by 1 gives 3; move then scale gives 4.
  expect_vec(with_triangle("<translate dx='1'><scale dx='2' dy='2' dz='2'><object name='t'/></scale></translate>")
                 .patches[0]
                 .v[1],
             {3, 0, 0});
  expect_vec(with_triangle("<scale dx='2' dy='2' dz='2'><translate dx='1'><object name='t'/></translate></scale>")
                 .patches[0]
                 .v[1],
             {4, 0, 0});
}

TEST(Transforms, MissingComponentsAreZero) {
  // translate names only dy: x and z do not move.
  expect_vec(with_triangle("<translate dy='5'><object name='t'/></translate>").patches[0].v[1], {1, 5, 0});
  // scale names dx and dy: z collapses to 0 (harmless for a triangle in z = 0).
  const Mesh m = with_triangle("<scale dx='2' dy='3'><object name='t'/></scale>", {0, 0, 1}, {1, 0, 1}, {0, 1, 1});
  expect_vec(m.patches[0].v[1], {2, 0, 0});
  expect_vec(m.patches[0].v[2], {0, 3, 0});
}

TEST(Transforms, RotationAboutXAndZFollowsTheRightHandRule) {
  expect_vec(with_triangle("<rotate angle='90' dx='1'><object name='t'/></rotate>").patches[0].v[2], {0, 0, 1});
  expect_vec(with_triangle("<rotate angle='90' dz='1'><object name='t'/></rotate>").patches[0].v[1], {0, 1, 0});
}

TEST(Transforms, RotationAboutYIsRrvsOppositeSense) {
  // RRV turns +z to -x at +90° about +y (the right-hand rule gives +x): with it, RRV's rooms face inwards.
  const Mesh m =
      with_triangle("<rotate angle='90' dy='1'><object name='t'/></rotate>", {0, 0, 1}, {1, 0, 0}, {0, 1, 0});
  expect_vec(m.patches[0].v[0], {-1, 0, 0});
  expect_vec(m.patches[0].v[1], {0, 0, 1});
  // The axis is normalised, its sign kept: 90° about -y is -90° about y; a longer axis is the same axis.
  expect_vec(with_triangle("<rotate angle='90' dy='-1'><object name='t'/></rotate>", {0, 0, 1}).patches[0].v[0],
             {1, 0, 0});
  expect_vec(with_triangle("<rotate angle='90' dy='7'><object name='t'/></rotate>", {0, 0, 1}).patches[0].v[0],
             {-1, 0, 0});
}

TEST(Transforms, RotationAboutAnOddAxisIsRrvsPerAxisComposition) {
  // RRV (TransformMatrix::rotate) scales the unit axis by the angle and multiplies rotations about x, y and z by
  // those components onto its matrix in that order, so a vertex is turned about z first, then y, then x. Axis
  // (1,1,0) at 90°: θx = θy = 90°/√2, θz = 0, and (0,0,1) turns about y (RRV's sense) to (-sin θy, 0, cos θy),
  // then about x to (-sin θy, -cos θy sin θx, cos θy cos θx). A true rotation about (1,1,0) would differ.
  const double t = 3.14159265358979323846 / 2 / std::sqrt(2.0);
  const Mesh m = with_triangle("<rotate angle='90' dx='1' dy='1'><object name='t'/></rotate>", {0, 0, 1});
  expect_vec(m.patches[0].v[0], {-std::sin(t), -std::cos(t) * std::sin(t), std::cos(t) * std::cos(t)});
}

TEST(Transforms, ShearHasNoEffect) {
  const Mesh plain = with_triangle("<object name='t'/>");
  const Mesh sheared = with_triangle("<shear dx='1' dy='2' dz='3'><object name='t'/></shear>");
  for (int k = 0; k < 3; ++k) expect_vec(sheared.patches[0].v[k], plain.patches[0].v[k]);
}

TEST(Strips, TrianglenextAlternatesAndTriangleRestarts) {
  // (a b c), then per FORMAT.md: 1st next n1 -> (b n1 c); 2nd n2 -> (c n1 n2); 3rd n3 -> (n1 n3 n2);
  // a new triangle (d e f) restarts: its 1st next n4 -> (e n4 f).
  const Mesh m = strip("<triangle>" + v(0, 0, 0) + v(1, 0, 0) + v(0, 1, 0) + "</triangle>" + "<trianglenext>" +
                       v(1, 1, 0) + "</trianglenext>" + "<trianglenext>" + v(0, 2, 0) + "</trianglenext>" +
                       "<trianglenext>" + v(1, 2, 0) + "</trianglenext>" + "<triangle>" + v(5, 0, 0) + v(6, 0, 0) +
                       v(5, 1, 0) + "</triangle>" + "<trianglenext>" + v(6, 1, 0) + "</trianglenext>");
  ASSERT_EQ(m.size(), 6u);
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0}, n1{1, 1, 0}, n2{0, 2, 0}, n3{1, 2, 0};
  const Vec3 d{5, 0, 0}, e{6, 0, 0}, f{5, 1, 0}, n4{6, 1, 0};
  const std::vector<std::array<Vec3, 3>> want = {{a, b, c},    {b, n1, c}, {c, n1, n2},
                                                 {n1, n3, n2}, {d, e, f},  {e, n4, f}};
  for (size_t t = 0; t < want.size(); ++t)
    for (int k = 0; k < 3; ++k) expect_vec(m.patches[t].v[k], want[t][k]);
}

TEST(Colours, TriangleOverridesItsSetAndMissingIsZero) {
  const Mesh m = strip("<triangle emission='2,3,4'>" + v(0, 0, 0) + v(1, 0, 0) + v(0, 1, 0) + "</triangle>" +
                           "<trianglenext radiosity='.1,.2,.3'>" + v(1, 1, 0) + "</trianglenext>" + "<triangle>" +
                           v(5, 0, 0) + v(6, 0, 0) + v(5, 1, 0) + "</triangle>",
                       "reflectivity=' .5 , .25,0.125 ' emission='1,1,1'");
  ASSERT_EQ(m.size(), 3u);
  const radiosity::Rgb set_rho{.5, .25, .125}, zero{0, 0, 0};
  EXPECT_EQ(m.patches[0].emission, (radiosity::Rgb{2, 3, 4}));  // own
  EXPECT_EQ(m.patches[0].reflectivity, set_rho);                // the set's
  EXPECT_EQ(m.patches[0].radiosity, zero);                      // nowhere: 0
  // A trianglenext continues its strip's colours; its own attribute overrides.
  EXPECT_EQ(m.patches[1].emission, (radiosity::Rgb{2, 3, 4}));
  EXPECT_EQ(m.patches[1].radiosity, (radiosity::Rgb{.1, .2, .3}));
  // A new triangle starts again from the set's.
  EXPECT_EQ(m.patches[2].emission, (radiosity::Rgb{1, 1, 1}));
  EXPECT_EQ(m.patches[2].reflectivity, set_rho);
}

TEST(Subdivision, SplitsAtMidpointsUntilAtMostTheLimit) {
  // Area 2 at limit 1: four pieces of 0.5 at the edge midpoints, keeping the orientation; area exactly 1 stays.
  const Mesh m = strip("<triangle>" + v(0, 0, 0) + v(2, 0, 0) + v(0, 2, 0) + "</triangle>", "", 1.0);
  ASSERT_EQ(m.size(), 4u);
  for (const radiosity::Patch& p : m.patches) {
    EXPECT_DOUBLE_EQ(p.area(), 0.5);
    expect_vec(p.normal(), {0, 0, 1});
  }
  expect_vec(m.patches[0].v[0], {0, 0, 0});
  expect_vec(m.patches[0].v[1], {1, 0, 0});
  expect_vec(m.patches[0].v[2], {0, 1, 0});
  expect_vec(m.patches[3].centroid(), {2.0 / 3, 2.0 / 3, 0});  // the middle piece last, as in RRV
  EXPECT_EQ(strip("<triangle>" + v(0, 0, 0) + v(1, 0, 0) + v(0, 2, 0) + "</triangle>", "", 1.0).size(), 1u);
}

TEST(Subdivision, IsBreadthFirstWithinAnEntity) {
  // A (area 8, two levels: 16 pieces) then B (area 0.5): B is popped before A's pieces, so it comes first.
  const Mesh m = strip("<triangle>" + v(0, 0, 0) + v(4, 0, 0) + v(0, 4, 0) + "</triangle>" +
                           "<triangle emission='1,0,0'>" + v(9, 0, 0) + v(10, 0, 0) + v(9, 1, 0) + "</triangle>",
                       "", 1.0);
  ASSERT_EQ(m.size(), 17u);
  EXPECT_EQ(m.patches[0].emission, (radiosity::Rgb{1, 0, 0}));
  EXPECT_NEAR(scene_test::total_area(m), 8.5, 1e-12);
}

TEST(Entities, OnePerTrianglesetOrPrimitiveInstanceInBodyOrder) {
  const Mesh m = radiosity::load_rrv_scene_string(
      "<scene><head>"
      "<objectdef name='pair'><cuboid/><triangleset name='tri'><triangle>" +
      v(0, 0, 0) + v(1, 0, 0) + v(0, 1, 0) +
      "</triangle></triangleset></objectdef>"
      "<objectdef name='ball'><globe name='b'/></objectdef>"
      "</head><body><object name='ball'/><translate dx='5'><object name='pair'/></translate></body></scene>");
  EXPECT_EQ(m.entities, (std::vector<std::string>{"b", "pair/cuboid", "tri"}));
  ASSERT_EQ(m.size(), 360u + 12u + 1u);
  EXPECT_EQ(m.patches[0].entity, 0);
  EXPECT_EQ(m.patches[359].entity, 0);
  EXPECT_EQ(m.patches[360].entity, 1);
  EXPECT_EQ(m.patches[372].entity, 2);
}

TEST(Attributes, RrvsRayTracingAttributesAreAcceptedAndIgnored) {
  // RRV writes spec, refl and refr into its output; its files must read back.
  EXPECT_EQ(
      strip("<triangle spec='1' refl='0' refr='0'>" + v(0, 0, 0) + v(1, 0, 0) + v(0, 1, 0) + "</triangle>").size(), 1u);
}
