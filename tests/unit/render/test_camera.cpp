// parse_view: the named views see the whole scene (or, inside, look along -z from within it), the explicit form
// is read exactly, garbage is a UsageError that lists the accepted forms.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>

#include "common/errors.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/render/render.hpp"
#include "render_test_util.hpp"

using radiosity::Camera;
using radiosity::Mesh;
using radiosity::parse_view;
using radiosity::Vec3;

namespace {

const double kPi = 3.14159265358979323846;

// A box [-1, 3] × [0, 2] × [-5, -1] as two triangles spanning its diagonal corners and two more for the rest.
Mesh box() {
  Mesh m;
  m.patches.push_back(render_test::patch({-1, 0, -5}, {3, 2, -1}, {3, 0, -5}));
  m.patches.push_back(render_test::patch({-1, 2, -1}, {3, 0, -1}, {-1, 0, -5}));
  return m;
}

std::vector<Vec3> corners() {
  std::vector<Vec3> c;
  for (double x : {-1, 3})
    for (double y : {0, 2})
      for (double z : {-5, -1}) c.push_back({x, y, z});
  return c;
}

// Every corner of the box within the cone of view, and the eye outside the box.
void expect_sees_whole_box(const Camera& cam) {
  const Vec3 f = (cam.target - cam.eye).normalized();
  for (const Vec3& c : corners()) {
    const Vec3 d = (c - cam.eye).normalized();
    EXPECT_LE(std::acos(d.dot(f)) * 180 / kPi, 0.5 * cam.fov_deg + 1e-9);
  }
  const bool inside = cam.eye.x > -1 && cam.eye.x < 3 && cam.eye.y > 0 && cam.eye.y < 2 && cam.eye.z > -5 &&
                      cam.eye.z < -1;
  EXPECT_FALSE(inside);
  EXPECT_NEAR((cam.target - Vec3{1, 1, -3}).norm(), 0, 1e-12);
}

std::string usage_message(const std::string& spec) {
  try {
    parse_view(spec, box());
  } catch (const hpcgi::UsageError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(Camera, AutoSeesTheWholeBoxFromFrontUpperRight) {
  const Camera cam = parse_view("auto", box());
  expect_sees_whole_box(cam);
  EXPECT_GT(cam.eye.x, 1);
  EXPECT_GT(cam.eye.y, 1);
  EXPECT_GT(cam.eye.z, -1);
  EXPECT_EQ(cam.up.y, 1);
}

TEST(Camera, FrontAndTopLookAlongTheAxes) {
  const Camera front = parse_view("front", box());
  expect_sees_whole_box(front);
  EXPECT_DOUBLE_EQ(front.eye.x, 1);
  EXPECT_DOUBLE_EQ(front.eye.y, 1);
  EXPECT_GT(front.eye.z, -1);

  const Camera top = parse_view("top", box());
  expect_sees_whole_box(top);
  EXPECT_DOUBLE_EQ(top.eye.x, 1);
  EXPECT_DOUBLE_EQ(top.eye.z, -3);
  EXPECT_GT(top.eye.y, 2);
  EXPECT_EQ(top.up.z, -1);  // looking down, the front (+z) at the bottom of the picture
}

TEST(Camera, InsideLooksAlongMinusZFromWithinTheBox) {
  const Camera cam = parse_view("inside", box());
  EXPECT_DOUBLE_EQ(cam.eye.x, 1);
  EXPECT_DOUBLE_EQ(cam.eye.y, 1);
  EXPECT_GT(cam.eye.z, -3);  // a little behind the centre
  EXPECT_LT(cam.eye.z, -1);
  const Vec3 f = (cam.target - cam.eye).normalized();
  EXPECT_NEAR(f.z, -1, 1e-12);
}

TEST(Camera, ExplicitEyeTargetAndFov) {
  const Camera a = parse_view("1,2.5,-3:0,0,1e1", Mesh{});
  EXPECT_EQ(a.eye.x, 1);
  EXPECT_EQ(a.eye.y, 2.5);
  EXPECT_EQ(a.eye.z, -3);
  EXPECT_EQ(a.target.z, 10);
  EXPECT_EQ(a.fov_deg, 60);
  EXPECT_EQ(a.up.y, 1);
  const Camera b = parse_view("0,0,5:0,0,0:35.5", Mesh{});
  EXPECT_EQ(b.fov_deg, 35.5);
  // Straight down: +y cannot be up, so the camera picks -z.
  const Camera c = parse_view("0,5,0:0,0,0", Mesh{});
  EXPECT_EQ(c.up.z, -1);
}

TEST(Camera, GarbageIsAUsageErrorListingTheForms) {
  for (const std::string spec :
       {"", "sideways", "Auto", "1,2:3,4,5", "1,2,3:4,5", "1,2,3", "1,2,3:1,2,3", "1,2,3:4,5,6:0", "1,2,3:4,5,6:180",
        "1,2,3:4,5,6:60:1", "1,2,x:0,0,0", "1,2,3:4,5,6:", "nan,0,0:0,0,0", "1e999,0,0:0,0,0", "1,2,3,:4,5,6",
        " 1,2,3:4,5,6", "1,2,3 :4,5,6"}) {
    const std::string msg = usage_message(spec);
    EXPECT_NE(msg.find("expected auto, front, top, inside or ex,ey,ez:tx,ty,tz[:fov]"), std::string::npos)
        << "'" << spec << "': " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos);
  }
}

TEST(Camera, NamedViewsNeedAMeshWithExtent) {
  EXPECT_THROW(parse_view("auto", Mesh{}), hpcgi::UsageError);
  Mesh point;
  point.patches.push_back(render_test::patch({1, 1, 1}, {1, 1, 1}, {1, 1, 1}));
  EXPECT_THROW(parse_view("front", point), hpcgi::UsageError);
}

// Through the named views the picture is the right way round: seen from the front +x is right and +y up; seen
// from the top +z (the front) is at the bottom.
TEST(Camera, NamedViewsShowThePictureTheRightWayRound) {
  // A floor square [-1, 1]² at y = 0, dark, with a bright triangle at the +x, +z corner, raised to y = 0.5 so the
  // front view sees it above the floor's centre line.
  Mesh m;
  m.patches.push_back(render_test::patch({-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {0.2, 0.2, 0.2}));
  m.patches.push_back(render_test::patch({-1, 0, -1}, {1, 0, 1}, {-1, 0, 1}, {0.2, 0.2, 0.2}));
  m.patches.push_back(render_test::patch({0.5, 0.5, 0.5}, {1, 0.5, 0.5}, {1, 0.5, 1}, {1, 1, 1}));
  radiosity::RenderOptions opt;
  opt.flat = true;
  // The centre of the bright pixels.
  auto bright_centre = [&](const std::string& view) {
    const radiosity::Image img = radiosity::render(m, render_test::radiosity_of(m), parse_view(view, m), 100, 100, opt);
    double sx = 0, sy = 0;
    int n = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x)
        if (img.at(x, y)[0] == 255) sx += x, sy += y, ++n;
    EXPECT_GT(n, 0) << view;
    return std::array<double, 2>{sx / n, sy / n};
  };
  const auto front = bright_centre("front");
  EXPECT_GT(front[0], 50);  // right
  EXPECT_LT(front[1], 50);  // up
  const auto top = bright_centre("top");
  EXPECT_GT(top[0], 50);  // right
  EXPECT_GT(top[1], 50);  // front at the bottom
}
