// Geometry of the rasteriser: which pixels a triangle covers, depth order, both sides, near-plane clipping.
#include <gtest/gtest.h>

#include <cmath>

#include "common/errors.hpp"
#include "radiosity/render/render.hpp"
#include "render_test_util.hpp"

using radiosity::Camera;
using radiosity::Image;
using radiosity::Mesh;
using radiosity::render;
using render_test::front_camera;
using render_test::linear;
using render_test::patch;
using render_test::radiosity_of;

namespace {

const double kF = 100 / std::tan(3.14159265358979323846 / 6);  // focal length in pixels for a 200-pixel side

bool black(const Image& img, int x, int y) {
  const auto p = img.at(x, y);
  return p[0] == 0 && p[1] == 0 && p[2] == 0;
}

// Pixel coordinates of (x, y, 0) for front_camera() on a 300 × 200 picture.
double px(double x) { return 150 + kF * x / 5; }
double py(double y) { return 100 - kF * y / 5; }

}  // namespace

TEST(Rasterize, TriangleFacingTheCameraFillsItsProjection) {
  Mesh m;
  m.patches.push_back(patch({-1, -1, 0}, {1, -1, 0}, {0, 1, 0}, {1, 0.5, 0.25}));
  const Image img = render(m, radiosity_of(m), front_camera(), 300, 200, linear());
  ASSERT_EQ(img.width, 300);
  ASSERT_EQ(img.height, 200);
  // Inside: the centroid (0, -1/3) has the patch's colour.
  const auto inside = img.at(150, static_cast<int>(py(-1.0 / 3)));
  EXPECT_EQ(inside[0], 255);
  EXPECT_EQ(inside[1], 128);
  EXPECT_EQ(inside[2], 64);
  // The bottom edge y = -1 lies on row py(-1) ≈ 134.6: the row above is in, the one below out.
  EXPECT_FALSE(black(img, 150, static_cast<int>(std::floor(py(-1))) - 1));
  EXPECT_TRUE(black(img, 150, static_cast<int>(std::ceil(py(-1))) + 1));
  // Beside the apex and beside the bottom corners: background.
  EXPECT_TRUE(black(img, static_cast<int>(px(0.3)), static_cast<int>(py(0.8))));
  EXPECT_TRUE(black(img, static_cast<int>(px(1.1)), static_cast<int>(py(-0.9))));
  EXPECT_FALSE(black(img, static_cast<int>(px(0.9)), static_cast<int>(py(-0.95))));
  EXPECT_TRUE(black(img, 5, 5));
  // The covered area is the projected area: base 2·f/5, height 2·f/5 pixels, halved.
  int covered = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) covered += !black(img, x, y);
  const double expected = 0.5 * (2 * kF / 5) * (2 * kF / 5);
  EXPECT_NEAR(covered, expected, 0.03 * expected);
}

TEST(Rasterize, BackSideIsDrawnTheSame) {
  Mesh front, back;
  front.patches.push_back(patch({-1, -1, 0}, {1, -1, 0}, {0, 1, 0}, {0.5, 0.5, 0.5}));
  back.patches.push_back(patch({-1, -1, 0}, {0, 1, 0}, {1, -1, 0}, {0.5, 0.5, 0.5}));
  const Image a = render(front, radiosity_of(front), front_camera(), 300, 200, linear());
  const Image b = render(back, radiosity_of(back), front_camera(), 300, 200, linear());
  EXPECT_FALSE(black(b, 150, 110));
  EXPECT_EQ(a.rgb, b.rgb);
}

TEST(Rasterize, NearerTriangleWinsWhateverTheDrawOrder) {
  const radiosity::Patch far_red = patch({-2, -2, 0}, {2, -2, 0}, {0, 2, 0}, {1, 0, 0});
  const radiosity::Patch near_green = patch({-1, -1, 1}, {1, -1, 1}, {0, 1, 1}, {0, 1, 0});
  for (bool near_first : {false, true}) {
    Mesh m;
    m.patches = near_first ? std::vector<radiosity::Patch>{near_green, far_red}
                           : std::vector<radiosity::Patch>{far_red, near_green};
    const Image img = render(m, radiosity_of(m), front_camera(), 300, 200, linear());
    const auto centre = img.at(150, 105);
    EXPECT_EQ(centre[0], 0) << "near_first " << near_first;
    EXPECT_EQ(centre[1], 255) << "near_first " << near_first;
    // Outside the green one, the red one shows.
    const auto side = img.at(static_cast<int>(px(-1.5)), static_cast<int>(py(-1.8)));
    EXPECT_EQ(side[0], 255);
    EXPECT_EQ(side[1], 0);
  }
}

// A square cut into a grid of triangles, some of whose edges pass exactly through pixel centres (the diagonals
// through the middle of a picture of even size): no pixel inside may fall between two triangles.
TEST(Rasterize, SharedEdgesLeaveNoCracks) {
  Mesh m;
  const int n = 8;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x0 = -1 + 2.0 * i / n, x1 = -1 + 2.0 * (i + 1) / n;
      const double y0 = -1 + 2.0 * j / n, y1 = -1 + 2.0 * (j + 1) / n;
      if ((i < n / 2) == (j < n / 2)) {  // diagonals along y = x
        m.patches.push_back(patch({x0, y0, 0}, {x1, y0, 0}, {x1, y1, 0}, {1, 1, 1}));
        m.patches.push_back(patch({x0, y0, 0}, {x1, y1, 0}, {x0, y1, 0}, {1, 1, 1}));
      } else {  // along y = -x
        m.patches.push_back(patch({x0, y0, 0}, {x1, y0, 0}, {x0, y1, 0}, {1, 1, 1}));
        m.patches.push_back(patch({x1, y0, 0}, {x1, y1, 0}, {x0, y1, 0}, {1, 1, 1}));
      }
    }
  for (int size : {200, 256, 400, 640}) {
    const Image img = render(m, radiosity_of(m), front_camera(), size, size, linear());
    const double f = 0.5 * size / std::tan(3.14159265358979323846 / 6) / 5;  // pixels per unit at z = 0
    int cracks = 0;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const double u = (x + 0.5 - 0.5 * size) / f, v = (0.5 * size - y - 0.5) / f;
        if (std::abs(u) < 0.99 && std::abs(v) < 0.99) cracks += black(img, x, y);
      }
    EXPECT_EQ(cracks, 0) << size << " x " << size;
  }
}

TEST(Rasterize, TriangleBehindTheCameraIsNotDrawn) {
  Mesh m;
  m.patches.push_back(patch({-1, -1, 6}, {1, -1, 6}, {0, 1, 6}, {1, 1, 1}));
  const Image img = render(m, radiosity_of(m), front_camera(), 300, 200, linear());
  for (unsigned char c : img.rgb) ASSERT_EQ(c, 0);
}

// Standing 1 above a floor that reaches far out in every direction, behind the eye too, looking at the horizon:
// the floor is below the horizon (the middle row) and nothing is above it. Without clipping, the corners behind
// the eye would project above the horizon.
TEST(Rasterize, FloorCrossingTheNearPlaneCoversTheLowerHalf) {
  const double r = 1000;
  Mesh m;
  m.patches.push_back(patch({-r, 0, -r}, {r, 0, -r}, {r, 0, r}, {0.5, 0.5, 0.5}));
  m.patches.push_back(patch({-r, 0, -r}, {r, 0, r}, {-r, 0, r}, {0.5, 0.5, 0.5}));
  Camera cam;
  cam.eye = {0, 1, 0};
  cam.target = {0, 1, -1};
  const int w = 160, h = 120;
  const Image img = render(m, radiosity_of(m), cam, w, h, linear());
  // The far edge z = -1000 shows f/1000 ≈ 0.1 pixel below the horizon, above the centre of row h/2.
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) ASSERT_EQ(black(img, x, y), y < h / 2) << "pixel " << x << "," << y;
  }
  EXPECT_EQ(img.at(w / 2, h - 1)[0], 128);
}

TEST(Rasterize, BadArgumentsAreUsageErrors) {
  Mesh m;
  m.patches.push_back(patch({-1, -1, 0}, {1, -1, 0}, {0, 1, 0}));
  const auto b = radiosity_of(m);
  const Camera cam = front_camera();
  EXPECT_THROW(render(m, {}, cam, 10, 10), hpcgi::UsageError);
  EXPECT_THROW(render(m, b, cam, 0, 10), hpcgi::UsageError);
  EXPECT_THROW(render(m, b, cam, 10, -1), hpcgi::UsageError);
  Camera same = cam;
  same.target = same.eye;
  EXPECT_THROW(render(m, b, same, 10, 10), hpcgi::UsageError);
  Camera along_up = cam;
  along_up.target = {0, 10, 5};
  EXPECT_THROW(render(m, b, along_up, 10, 10), hpcgi::UsageError);
  Camera wide = cam;
  wide.fov_deg = 180;
  EXPECT_THROW(render(m, b, wide, 10, 10), hpcgi::UsageError);
  radiosity::RenderOptions opt;
  opt.gamma = 0;
  EXPECT_THROW(render(m, b, cam, 10, 10, opt), hpcgi::UsageError);
  opt = {};
  opt.exposure = -1;
  EXPECT_THROW(render(m, b, cam, 10, 10, opt), hpcgi::UsageError);
}
