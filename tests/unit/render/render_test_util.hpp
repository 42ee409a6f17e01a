// Small scenes for the renderer's tests.
#pragma once
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/render/render.hpp"

namespace render_test {

inline radiosity::Patch patch(radiosity::Vec3 a, radiosity::Vec3 b, radiosity::Vec3 c, radiosity::Rgb radiosity = {}) {
  radiosity::Patch p;
  p.v = {a, b, c};
  p.radiosity = radiosity;
  return p;
}

inline std::vector<radiosity::Rgb> radiosity_of(const radiosity::Mesh& m) {
  std::vector<radiosity::Rgb> b;
  for (const radiosity::Patch& p : m.patches) b.push_back(p.radiosity);
  return b;
}

// Gamma 1, exposure 1: a pixel is round(255 · B), so tests can read radiosity back from the picture.
inline radiosity::RenderOptions linear() {
  radiosity::RenderOptions opt;
  opt.gamma = 1;
  return opt;
}

// Looking along -z from (0, 0, 5) at the origin with a 60 degree lens: a point (x, y, 0) shows at pixel
// (w/2 + f·x/5, h/2 - f·y/5) with f = min(w, h)/2 / tan(30°).
inline radiosity::Camera front_camera() {
  radiosity::Camera cam;
  cam.eye = {0, 0, 5};
  cam.target = {0, 0, 0};
  return cam;
}

}  // namespace render_test
