// Colours: smooth shading across shared vertices (area-weighted, kept apart at creases), flat shading, and the
// exposure/gamma mapping to 8 bits.
#include <gtest/gtest.h>

#include <cmath>

#include "radiosity/render/render.hpp"
#include "radiosity/render/vertex_colours.hpp"
#include "render_test_util.hpp"

using radiosity::Image;
using radiosity::Mesh;
using radiosity::render;
using render_test::front_camera;
using render_test::linear;
using render_test::patch;
using render_test::radiosity_of;

namespace {

const double kF = 100 / std::tan(3.14159265358979323846 / 6);  // focal length in pixels for a 200-pixel side

// The pixel showing (x, y, 0) through front_camera() on a 200 × 200 picture.
int column(double x) { return static_cast<int>(std::floor(100 + kF * x / 5)); }
int row(double y) { return static_cast<int>(std::floor(100 - kF * y / 5)); }
std::array<std::uint8_t, 3> pixel_at(const Image& img, double x, double y) { return img.at(column(x), row(y)); }
// The x that column c samples (at its centre).
double sampled_x(int c) { return (c + 0.5 - 100) * 5 / kF; }

// Two patches sharing the edge (0, -1) - (0, 1): the left one, of area 1, is black, the right one, of area 3,
// white. The shared vertices get (1·0 + 3·1) / 4 = 0.75.
Mesh black_and_white() {
  Mesh m;
  m.patches.push_back(patch({0, -1, 0}, {0, 1, 0}, {-1, 0, 0}, {0, 0, 0}));
  m.patches.push_back(patch({0, -1, 0}, {3, 0, 0}, {0, 1, 0}, {1, 1, 1}));
  return m;
}

}  // namespace

TEST(Shading, SmoothShadingAveragesByAreaAtSharedVertices) {
  const Mesh m = black_and_white();
  const Image img = render(m, radiosity_of(m), front_camera(), 200, 200, linear());
  // At constant depth the shading is linear in x: 0.75 on the shared edge x = 0, falling to 0 at the left apex
  // x = -1 and rising to 1 at the right apex x = 3.
  auto left = [](double x) { return 255 * 0.75 * (1 + x); };
  auto right = [](double x) { return 255 * (0.75 + 0.25 * x / 3); };
  // Along the shared edge both sides show about 0.75 (191): the edge does not show.
  for (double y : {-0.5, 0.0, 0.5}) {
    EXPECT_NEAR(pixel_at(img, -0.01, y)[0], left(sampled_x(column(-0.01))), 1) << "y " << y;
    EXPECT_NEAR(pixel_at(img, 0.01, y)[0], right(sampled_x(column(0.01))), 1) << "y " << y;
    EXPECT_NEAR(pixel_at(img, 0.01, y)[0], 191, 4);
  }
  // Towards the far vertices, the pure colours.
  EXPECT_NEAR(pixel_at(img, -0.5, 0)[0], left(sampled_x(column(-0.5))), 1);
  EXPECT_LE(pixel_at(img, -0.97, 0)[0], 8);
  EXPECT_NEAR(pixel_at(img, 2.85, 0)[0], right(sampled_x(column(2.85))), 1);
  EXPECT_GE(pixel_at(img, 2.85, 0)[0], 251);
}

// The same two patches on the plane z = -x, receding to the right: the colour varies linearly along the surface,
// not across the screen, so the pixel value follows the point where the pixel's ray meets the plane.
TEST(Shading, InterpolationIsPerspectiveCorrect) {
  Mesh m = black_and_white();
  for (radiosity::Patch& p : m.patches)
    for (radiosity::Vec3& v : p.v) v.z = -v.x;
  const Image img = render(m, radiosity_of(m), front_camera(), 200, 200, linear());
  // The ray through column c, (0, 0, 5) + t (u, v, -1), meets z = -x at x = 5u / (1 - u).
  auto x_seen = [](int c) {
    const double u = (c + 0.5 - 100) / kF;
    return 5 * u / (1 - u);
  };
  for (double x : {-0.8, -0.5, -0.2, 0.5, 1.5, 2.5}) {
    const int c = static_cast<int>(std::floor(100 + kF * x / (5 + x)));  // where (x, 0, -x) shows
    const double xs = x_seen(c);
    const double expected = 255 * (xs < 0 ? 0.75 * (1 + xs) : 0.75 + 0.25 * xs / 3);
    EXPECT_NEAR(img.at(c, 100)[0], expected, 1) << "x " << x;
  }
}

TEST(Shading, FlatShadingShowsEachPatchsOwnColour) {
  const Mesh m = black_and_white();
  radiosity::RenderOptions opt = linear();
  opt.flat = true;
  const Image img = render(m, radiosity_of(m), front_camera(), 200, 200, opt);
  EXPECT_EQ(pixel_at(img, -0.02, 0)[0], 0);
  EXPECT_EQ(pixel_at(img, 0.02, 0)[0], 255);
  EXPECT_EQ(pixel_at(img, -0.95, 0)[0], 0);
}

TEST(Shading, VerticesMatchWithinATolerance) {
  Mesh m = black_and_white();
  m.patches[1].v[0].y += 1e-14;  // as a transform's rounding might leave it
  const auto corner = radiosity::smooth_vertex_colours(m, radiosity_of(m), 30);
  EXPECT_NEAR(corner[0][0][0], 0.75, 1e-12);
  EXPECT_NEAR(corner[1][0][0], 0.75, 1e-12);
  m.patches[1].v[0].y += 1e-3;  // a different point
  const auto apart = radiosity::smooth_vertex_colours(m, radiosity_of(m), 30);
  EXPECT_EQ(apart[0][0][0], 0);
  EXPECT_EQ(apart[1][0][0], 1);
  EXPECT_NEAR(apart[0][1][0], 0.75, 1e-3);  // the other shared vertex still matches
}

TEST(Shading, CreaseKeepsRoomCornersApart) {
  // A floor (y = 0, facing up) and a wall (x = 0, facing +x) meeting along the z axis.
  Mesh m;
  m.patches.push_back(patch({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {1, 0, 0}));
  m.patches.push_back(patch({0, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}));
  ASSERT_GT(m.patches[0].normal().y, 0.99);
  ASSERT_GT(m.patches[1].normal().x, 0.99);
  const auto sharp = radiosity::smooth_vertex_colours(m, radiosity_of(m), 30);
  EXPECT_EQ(sharp[0][0], (radiosity::Rgb{1, 0, 0}));
  EXPECT_EQ(sharp[1][0], (radiosity::Rgb{0, 0, 1}));
  const auto blended = radiosity::smooth_vertex_colours(m, radiosity_of(m), 180);
  EXPECT_EQ(blended[0][0], (radiosity::Rgb{0.5, 0, 0.5}));
  EXPECT_EQ(blended[1][2], (radiosity::Rgb{0.5, 0, 0.5}));
  EXPECT_EQ(blended[0][2], (radiosity::Rgb{1, 0, 0}));  // not shared
}

TEST(Shading, OppositeSidesOfAThinWallDoNotBlend) {
  Mesh m;
  m.patches.push_back(patch({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 1}));
  m.patches.push_back(patch({0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 0, 0}));
  const auto corner = radiosity::smooth_vertex_colours(m, radiosity_of(m), 30);
  EXPECT_EQ(corner[0][0], (radiosity::Rgb{1, 1, 1}));
  EXPECT_EQ(corner[1][0], (radiosity::Rgb{0, 0, 0}));
}

TEST(Shading, ExposureAndGammaMapAKnownValue) {
  Mesh m;
  m.patches.push_back(patch({-2, -2, 0}, {2, -2, 0}, {0, 2, 0}, {0.25, 0.125, 2}));
  radiosity::RenderOptions opt;
  opt.exposure = 2;
  opt.gamma = 2;
  const Image img = render(m, radiosity_of(m), front_camera(), 200, 200, opt);
  const auto p = pixel_at(img, 0, 0);
  EXPECT_EQ(p[0], 180);  // 255 · sqrt(0.5) = 180.3
  EXPECT_EQ(p[1], 128);  // 255 · sqrt(0.25) = 127.5
  EXPECT_EQ(p[2], 255);  // 4 clamps to 1
  opt = {};              // the defaults: exposure 1, gamma 2.2
  const auto q = pixel_at(render(m, radiosity_of(m), front_camera(), 200, 200, opt), 0, 0);
  EXPECT_EQ(q[0], 136);  // 255 · 0.25^(1/2.2) = 136.3
  EXPECT_EQ(q[1], 99);   // 255 · 0.125^(1/2.2) = 98.9
}

TEST(Shading, NegativeAndNanRadiosityShowBlack) {
  Mesh m;
  m.patches.push_back(patch({-2, -2, 0}, {2, -2, 0}, {0, 2, 0}, {-1, std::nan(""), 0.5}));
  const Image img = render(m, radiosity_of(m), front_camera(), 200, 200, linear());
  const auto p = pixel_at(img, 0, 0);
  EXPECT_EQ(p[0], 0);
  EXPECT_EQ(p[1], 0);
  EXPECT_EQ(p[2], 128);
}
