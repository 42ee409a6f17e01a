// Our scenes in radiosity/scenes/: the report's patch counts for scenes 1 and 2 (1312 and 3360 at maximum patch
// area 1.0, all ρ < 1 so they load with the default options and without RRV's files), and the geometry the
// analytic scenes promise in their comments.
#include <gtest/gtest.h>

#include "radiosity/scene/rrv_reader.hpp"
#include "scene_test_util.hpp"

using radiosity::Mesh;
using radiosity::Vec3;
using scene_test::own_scene;

namespace {

// The six walls (the first six entities) face the room's centre, and the walls enclose the room (closed).
void expect_closed_room(const Mesh& m, const Vec3& centre) {
  Mesh walls;
  for (const radiosity::Patch& p : m.patches) {
    if (p.entity >= 6) continue;
    ASSERT_GT(p.normal().dot(centre - p.centroid()), 0) << "wall " << m.entities[p.entity] << " faces out";
    walls.patches.push_back(p);
  }
  EXPECT_NEAR(scene_test::vector_area(walls).norm(), 0, 1e-9);
  double emitted = 0;
  for (const radiosity::Patch& p : m.patches) emitted += p.area() * p.emission[0];
  EXPECT_GT(emitted, 0) << "no light";
}

Mesh entity(const Mesh& m, const std::string& name) {
  Mesh out;
  for (const radiosity::Patch& p : m.patches)
    if (m.entities[p.entity] == name) out.patches.push_back(p);
  return out;
}

}  // namespace

TEST(OwnScenes, Scene1Has1312Patches) {
  const Mesh m = radiosity::load_rrv_scene(own_scene("scene1.xml"));
  EXPECT_EQ(m.size(), 1312u);
  expect_closed_room(m, {0, 3, 0});
}

TEST(OwnScenes, Scene2Has3360Patches) {
  const Mesh m = radiosity::load_rrv_scene(own_scene("scene2.xml"));
  EXPECT_EQ(m.size(), 3360u);
  expect_closed_room(m, {0, 4, 0});
}

TEST(OwnScenes, ClosedBoxIsTheInsideOfTheUnitCube) {
  const Mesh m = radiosity::load_rrv_scene(own_scene("closed_box.xml"));
  EXPECT_EQ(m.size(), 12u);
  EXPECT_NEAR(scene_test::total_area(m), 6, 1e-12);
  EXPECT_NEAR(scene_test::vector_area(m).norm(), 0, 1e-12);
  for (const radiosity::Patch& p : m.patches) {
    EXPECT_GT(p.normal().dot(Vec3{.5, .5, .5} - p.centroid()), 0);
    EXPECT_EQ(p.emission, (radiosity::Rgb{1, 1, 1}));
    EXPECT_EQ(p.reflectivity, (radiosity::Rgb{.5, .5, .5}));
  }
}

TEST(OwnScenes, FacingSquaresAreUnitSquaresOneApart) {
  const Mesh m = radiosity::load_rrv_scene(own_scene("facing_squares.xml"));
  const Mesh lower = entity(m, "lower"), upper = entity(m, "upper");
  EXPECT_NEAR(scene_test::total_area(lower), 1, 1e-12);
  EXPECT_NEAR(scene_test::total_area(upper), 1, 1e-12);
  for (const radiosity::Patch& p : lower.patches) {
    EXPECT_EQ(p.centroid().z, 0);
    EXPECT_EQ(p.normal().z, 1);
  }
  for (const radiosity::Patch& p : upper.patches) {
    EXPECT_EQ(p.centroid().z, 1);
    EXPECT_EQ(p.normal().z, -1);
  }
}

TEST(OwnScenes, PerpendicularSquaresShareAnEdge) {
  const Mesh m = radiosity::load_rrv_scene(own_scene("perpendicular_squares.xml"));
  const Mesh floor = entity(m, "floor"), wall = entity(m, "wall");
  EXPECT_NEAR(scene_test::total_area(floor), 1, 1e-12);
  EXPECT_NEAR(scene_test::total_area(wall), 1, 1e-12);
  for (const radiosity::Patch& p : floor.patches) EXPECT_EQ(p.normal().z, 1);
  for (const radiosity::Patch& p : wall.patches) EXPECT_EQ(p.normal().x, 1);
  // Both squares have the corners (0,0,0) and (0,1,0).
  for (const Mesh* sq : {&floor, &wall})
    for (const Vec3& corner : {Vec3{0, 0, 0}, Vec3{0, 1, 0}}) {
      bool found = false;
      for (const radiosity::Patch& p : sq->patches)
        for (const Vec3& v : p.v) found = found || (v - corner).norm() == 0;
      EXPECT_TRUE(found);
    }
}
