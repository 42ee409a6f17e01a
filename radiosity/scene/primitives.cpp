// The primitives of RRV 2007 (CuboidEntity, BarrelEntity, GlobeEntity), rebuilt vertex for vertex in double.
#include "radiosity/scene/primitives.hpp"

#include <cmath>

namespace radiosity {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr int kSegments = 20;  // RRV's PLANE_COUNT for barrel and globe
constexpr double kRadius = 0.5;

// RRV splits each quad (q0 q1 q2 q3) into (q0 q1 q2) and (q0 q2 q3).
void add_quad(std::vector<Triangle>& out, const Vec3& q0, const Vec3& q1, const Vec3& q2, const Vec3& q3) {
  out.push_back({q0, q1, q2});
  out.push_back({q0, q2, q3});
}
}  // namespace

std::vector<Triangle> unit_cuboid() {
  const double h = 0.5;
  std::vector<Triangle> t;
  add_quad(t, {-h, -h, -h}, {-h, -h, +h}, {-h, +h, +h}, {-h, +h, -h});  // x = -0.5
  add_quad(t, {+h, -h, -h}, {+h, +h, -h}, {+h, +h, +h}, {+h, -h, +h});  // x = +0.5
  add_quad(t, {-h, -h, -h}, {+h, -h, -h}, {+h, -h, +h}, {-h, -h, +h});  // y = -0.5
  add_quad(t, {-h, +h, -h}, {-h, +h, +h}, {+h, +h, +h}, {+h, +h, -h});  // y = +0.5
  add_quad(t, {-h, -h, -h}, {-h, +h, -h}, {+h, +h, -h}, {+h, -h, -h});  // z = -0.5
  add_quad(t, {-h, -h, +h}, {+h, -h, +h}, {+h, +h, +h}, {-h, +h, +h});  // z = +0.5
  return t;
}

std::vector<Triangle> unit_barrel() {
  std::vector<Triangle> t;
  const Vec3 top_centre{0, 0.5, 0}, bottom_centre{0, -0.5, 0};
  auto top = [](int i) {
    const double a = 2 * kPi / kSegments * i;
    return Vec3{kRadius * std::cos(a), 0.5, kRadius * std::sin(a)};
  };
  for (int i = 1; i <= kSegments; ++i) {
    const Vec3 t0 = top(i - 1), t1 = top(i);
    const Vec3 b0{t0.x, -0.5, t0.z}, b1{t1.x, -0.5, t1.z};
    add_quad(t, t0, t1, b1, b0);           // side
    t.push_back({t1, t0, top_centre});     // top cap
    t.push_back({b0, b1, bottom_centre});  // bottom cap
  }
  return t;
}

std::vector<Triangle> unit_globe() {
  // Rings j = 0..10 from the top pole (polar angle 18° · j) to the bottom pole, 20 points around each.
  auto point = [](int j, int i) {
    if (j == 0) return Vec3{0, kRadius, 0};
    if (j == kSegments / 2) return Vec3{0, -kRadius, 0};
    const double polar = 2 * kPi / kSegments * j, around = 2 * kPi / kSegments * i;
    const double r = kRadius * std::sin(polar);
    return Vec3{r * std::cos(around), kRadius * std::cos(polar), r * std::sin(around)};
  };
  std::vector<Triangle> t;
  for (int j = 1; j <= kSegments / 2; ++j) {
    // RRV walks i = 2..21, i.e. the segments from 18°·(i-1) to 18°·i, starting at 18°.
    for (int i = 2; i <= kSegments + 1; ++i) {
      const Vec3 now = point(j, i), prev = point(j, i - 1), up_prev = point(j - 1, i - 1), up = point(j - 1, i);
      // Of the quad (now prev up_prev up), the first triangle collapses on the bottom pole and the second on the
      // top pole; RRV drops those.
      if (j != kSegments / 2) t.push_back({now, prev, up_prev});
      if (j != 1) t.push_back({now, up_prev, up});
    }
  }
  return t;
}

}  // namespace radiosity
