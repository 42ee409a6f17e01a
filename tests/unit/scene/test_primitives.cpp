// RRV's primitives against FORMAT.md's table (triangle counts, unit size, centred, fronts outwards) and against
// geometry: a closed surface has zero vector area, and the cuboid's and the barrel's areas have closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "radiosity/scene/rrv_reader.hpp"
#include "scene_test_util.hpp"

using radiosity::LoadOptions;
using radiosity::Mesh;

namespace {

const double kPi = 3.14159265358979323846;

// One instance of a primitive, undivided.
Mesh primitive(const std::string& kind, const std::string& dir = "") {
  LoadOptions opt;
  opt.divide = 1e9;
  opt.primitive_dir = dir;
  return radiosity::load_rrv_scene_string("<scene><head><objectdef name='p'><" + kind +
                                              " reflectivity='.5,.5,.5'/></objectdef></head>"
                                              "<body><object name='p'/></body></scene>",
                                          opt);
}

void expect_unit_closed_outward(const Mesh& m) {
  for (const radiosity::Patch& p : m.patches) {
    for (const radiosity::Vec3& v : p.v)
      for (double c : {v.x, v.y, v.z}) ASSERT_LE(std::abs(c), 0.5 + 1e-12);
    ASSERT_GT(p.area(), 0);
    // Convex and centred at the origin: outward means the normal points away from the origin.
    ASSERT_GT(p.normal().dot(p.centroid()), 0);
  }
  const radiosity::Vec3 s = scene_test::vector_area(m);
  EXPECT_NEAR(s.norm(), 0, 1e-12) << "not closed";
}

}  // namespace

TEST(Primitives, CuboidIsTheUnitCubeIn12Triangles) {
  const Mesh m = primitive("cuboid");
  EXPECT_EQ(m.size(), 12u);
  expect_unit_closed_outward(m);
  EXPECT_NEAR(scene_test::total_area(m), 6.0, 1e-12);
}

TEST(Primitives, BarrelIsA20SidedPrismIn80Triangles) {
  const Mesh m = primitive("barrel");
  EXPECT_EQ(m.size(), 80u);
  expect_unit_closed_outward(m);
  const double r = 0.5;
  const double side = 20 * 2 * r * std::sin(kPi / 20);                // 20 rectangles chord × height 1
  const double caps = 2 * 20 * 0.5 * r * r * std::sin(2 * kPi / 20);  // two regular 20-gons
  EXPECT_NEAR(scene_test::total_area(m), side + caps, 1e-12);
}

TEST(Primitives, GlobeHas360TrianglesWithoutThePoleDegenerates) {
  const Mesh m = primitive("globe");
  EXPECT_EQ(m.size(), 360u);
  expect_unit_closed_outward(m);  // also: no triangle of zero area is left
  // An inscribed polyhedron of a sphere of radius 0.5: a little less than its area π.
  const double a = scene_test::total_area(m);
  EXPECT_LT(a, kPi);
  EXPECT_GT(a, 0.95 * kPi);
}

TEST(Primitives, TeapotIs3752TrianglesOfTeapotObjAsItIs) {
  REQUIRE_RRV_DIR(dir);
  const Mesh m = primitive("teapot", *dir);
  EXPECT_EQ(m.size(), 3752u);
  // The first face and its vertices, read from the file here: the triangle must be exactly them, in order.
  std::ifstream f(*dir + "/teapot.obj");
  std::vector<radiosity::Vec3> v;
  std::string line;
  long a = 0, b = 0, c = 0;
  while (std::getline(f, line)) {
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    if (key == "v") {
      radiosity::Vec3 p;
      ls >> p.x >> p.y >> p.z;
      v.push_back(p);
    } else if (key == "f") {
      ls >> a >> b >> c;
      break;
    }
  }
  ASSERT_GT(a, 0);
  const radiosity::Patch& first = m.patches[0];
  for (int k = 0; k < 3; ++k) {
    const radiosity::Vec3& want = v[(k == 0 ? a : k == 1 ? b : c) - 1];
    EXPECT_EQ(first.v[k].x, want.x);
    EXPECT_EQ(first.v[k].y, want.y);
    EXPECT_EQ(first.v[k].z, want.z);
  }
}

TEST(Primitives, TeapotObjIsFoundThroughRrvScenes) {
  REQUIRE_RRV_DIR(dir);
  scene_test::EnvGuard env("RRV_SCENES", dir->c_str());
  EXPECT_EQ(primitive("teapot").size(), 3752u);  // no primitive_dir, no scene file: only $RRV_SCENES is left
}
