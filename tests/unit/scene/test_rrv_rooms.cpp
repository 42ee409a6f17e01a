// RRV's own scenes, the fidelity check of the whole loader: the patch counts the report lists for them (scene 3
// = room3.xml: 9680, scene 4 = room2.xml: 17128, at maximum patch area 1.0; RRV's own output of room3 has 9680)
// and the refusal of room3's ρ = 1 barrel unless it is allowed.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "radiosity/scene/rrv_reader.hpp"
#include "scene_test_util.hpp"

using radiosity::load_rrv_scene;
using radiosity::LoadOptions;
using radiosity::Mesh;
using radiosity::Vec3;

namespace {

// Every patch of the six room walls (the entities cut from RRV's "xyplane" objectdefs) faces the room's centre.
// RRV lights the walls from inside, so this holds only with RRV's rotation convention.
void expect_walls_face(const Mesh& m, const Vec3& centre, size_t walls_expected) {
  size_t walls = 0, checked = 0;
  for (size_t e = 0; e < m.entities.size(); ++e) {
    if (m.entities[e] != "first" && m.entities[e] != "xyplane-green/triangleset") continue;
    ++walls;
    for (const radiosity::Patch& p : m.patches) {
      if (p.entity != static_cast<int>(e)) continue;
      ++checked;
      ASSERT_GT(p.normal().dot(centre - p.centroid()), 0) << "wall entity " << e << " faces away from the room";
    }
  }
  EXPECT_EQ(walls, walls_expected);
  EXPECT_GT(checked, 0u);
}

}  // namespace

TEST(RrvRooms, Room3IsRefusedForItsReflectivityOfOne) {
  REQUIRE_RRV_DIR(dir);
  const std::string path = *dir + "/room3.xml";
  // The line of the barrel with reflectivity "1,1,.8", found in the text independently of the loader.
  std::ifstream f(path);
  std::stringstream text;
  text << f.rdbuf();
  const std::string s = text.str();
  const size_t at = s.find("reflectivity=\"1,1,.8\"");
  ASSERT_NE(at, std::string::npos);
  const long line = 1 + std::count(s.begin(), s.begin() + static_cast<long>(at), '\n');
  scene_test::expect_refused([&] { load_rrv_scene(path); },
                             {path + ":" + std::to_string(line) + ":", "--allow-reflectivity-ge-1", "1,1,.8"});
}

TEST(RrvRooms, Room3Has9680PatchesWhenReflectivityOneIsAllowed) {
  REQUIRE_RRV_DIR(dir);
  LoadOptions opt;
  opt.allow_reflectivity_ge_1 = true;
  const Mesh m = load_rrv_scene(*dir + "/room3.xml", opt);
  EXPECT_EQ(m.size(), 9680u);
  expect_walls_face(m, {0, 0, 0}, 6);
  // The walls are the planes ±10 and nothing lies outside them.
  for (const radiosity::Patch& p : m.patches)
    for (const Vec3& v : p.v)
      for (double c : {v.x, v.y, v.z}) ASSERT_LE(std::abs(c), 10 + 1e-9);
}

TEST(RrvRooms, Room2Has17128Patches) {
  REQUIRE_RRV_DIR(dir);
  const Mesh m = load_rrv_scene(*dir + "/room2.xml");
  EXPECT_EQ(m.size(), 17128u);
  // room2's room is scaled and rotated about the origin and then moved by dx = -2.
  expect_walls_face(m, {-2, 0, 0}, 6);
}

TEST(RrvRooms, EveryPatchIsAtMostTheMaximumArea) {
  REQUIRE_RRV_DIR(dir);
  for (double divide : {1.0, 0.25}) {
    LoadOptions opt;
    opt.divide = divide;
    const Mesh m = load_rrv_scene(*dir + "/room2.xml", opt);
    for (const radiosity::Patch& p : m.patches) ASSERT_LE(p.area(), divide);
    // Subdivision cuts area, never adds or loses it: the total is that of the undivided scene.
    opt.divide = 1e9;
    const double whole = scene_test::total_area(load_rrv_scene(*dir + "/room2.xml", opt));
    EXPECT_NEAR(scene_test::total_area(m), whole, 1e-12 * whole);
  }
}
