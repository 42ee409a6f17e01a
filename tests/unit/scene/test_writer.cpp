// RRV-format output: written, then read back by the loader, it gives the same patches (positions and colours
// bit for bit, entities, order) and the radiosity it was given; nothing is left behind when writing fails.
#include <gtest/gtest.h>

#include <filesystem>
#include <pugixml.hpp>

#include "radiosity/scene/rrv_reader.hpp"
#include "radiosity/scene/rrv_writer.hpp"
#include "scene_test_util.hpp"

using radiosity::Mesh;
using radiosity::Rgb;

namespace {

std::vector<Rgb> some_radiosity(size_t n) {
  std::vector<Rgb> b(n);
  for (size_t i = 0; i < n; ++i) b[i] = {0.1 + 1e-3 * i, 1.0 / (i + 3), 2.5e-7 * i};
  return b;
}

}  // namespace

TEST(Writer, ReadsBackAsTheSamePatchesWithTheRadiosity) {
  scene_test::TempDir tmp;
  const Mesh m = radiosity::load_rrv_scene(scene_test::own_scene("scene2.xml"));
  const std::vector<Rgb> b = some_radiosity(m.size());
  const std::string out = (tmp.path() / "out.xml").string();
  radiosity::write_rrv_xml(out, m, b);
  EXPECT_FALSE(std::filesystem::exists(out + ".tmp"));

  // The same maximum patch area: every patch is already at or below it, so nothing is divided again.
  const Mesh back = radiosity::load_rrv_scene(out);
  ASSERT_EQ(back.size(), m.size());
  EXPECT_EQ(back.entities, m.entities);
  for (size_t i = 0; i < m.size(); ++i) {
    const radiosity::Patch &p = m.patches[i], &q = back.patches[i];
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(q.v[k].x, p.v[k].x) << "patch " << i;
      ASSERT_EQ(q.v[k].y, p.v[k].y) << "patch " << i;
      ASSERT_EQ(q.v[k].z, p.v[k].z) << "patch " << i;
    }
    ASSERT_EQ(q.emission, p.emission);
    ASSERT_EQ(q.reflectivity, p.reflectivity);
    ASSERT_EQ(q.radiosity, b[i]);
    ASSERT_EQ(q.entity, p.entity);
  }
  EXPECT_EQ(radiosity::mesh_hash(back), radiosity::mesh_hash(m));
}

TEST(Writer, FailureLeavesNothingBehind) {
  scene_test::TempDir tmp;
  const Mesh m = radiosity::load_rrv_scene(scene_test::own_scene("closed_box.xml"));
  const std::string out = (tmp.path() / "missing-folder" / "out.xml").string();
  EXPECT_THROW(radiosity::write_rrv_xml(out, m, some_radiosity(m.size())), std::runtime_error);
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
  // A radiosity per patch, no more and no fewer.
  EXPECT_THROW(radiosity::write_rrv_xml((tmp.path() / "x.xml").string(), m, some_radiosity(m.size() - 1)),
               std::invalid_argument);
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
}

TEST(Writer, OutputIsRrvsFlatLayout) {
  scene_test::TempDir tmp;
  const Mesh m = radiosity::load_rrv_scene(scene_test::own_scene("facing_squares.xml"));
  const std::string out = (tmp.path() / "out.xml").string();
  radiosity::write_rrv_xml(out, m, some_radiosity(m.size()));
  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_file(out.c_str()));
  const pugi::xml_node def = doc.child("scene").child("head").child("objectdef");
  EXPECT_STREQ(def.attribute("name").value(), "scene");
  EXPECT_TRUE(def.next_sibling().empty());
  EXPECT_STREQ(doc.child("scene").child("body").child("object").attribute("name").value(), "scene");
  size_t sets = 0, triangles = 0;
  for (const pugi::xml_node& set : def.children("triangleset")) {
    ++sets;
    for (const pugi::xml_node& t : set.children()) {
      EXPECT_STREQ(t.name(), "triangle");
      EXPECT_TRUE(t.attribute("emission") && t.attribute("reflectivity") && t.attribute("radiosity"));
      ++triangles;
    }
  }
  EXPECT_EQ(sets, m.entities.size());
  EXPECT_EQ(triangles, m.size());
}
