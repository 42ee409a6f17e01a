// Projection, near-plane clipping, z-buffered rasterisation and tone mapping; see render.hpp.
#include "radiosity/render/render.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/render/vertex_colours.hpp"

namespace radiosity {
namespace {

const double kPi = 3.14159265358979323846;

// A point in camera space: x right, y up, z the distance along the view direction; c its linear radiosity.
struct ViewVertex {
  Vec3 p;
  Rgb c;
};

// A projected vertex: pixel coordinates, w = 1/z, and c·w, which (unlike c) vary linearly across the screen.
struct ScreenVertex {
  double x, y, w;
  Rgb cw;
};

struct ScreenTriangle {
  ScreenVertex v[3];
  double inv_area2;  // 1 / (twice the signed screen area), the sign making the edge tests face-independent
  int x0, x1, y0, y1;  // pixel bounding box, clamped to the image
};

struct Basis {
  Vec3 right, up, forward;
};

Basis camera_basis(const Camera& cam) {
  const Vec3 view = cam.target - cam.eye;
  if (!(view.norm() > 0) || !std::isfinite(view.norm()))
    throw hpcgi::UsageError("camera: eye and target must be distinct finite points");
  if (!(cam.fov_deg > 0 && cam.fov_deg < 180)) throw hpcgi::UsageError("camera: fov must be in (0, 180) degrees");
  Basis b;
  b.forward = view.normalized();
  const Vec3 side = b.forward.cross(cam.up);
  if (!(side.norm() > 1e-9 * cam.up.norm())) throw hpcgi::UsageError("camera: up is along the view direction");
  b.right = side.normalized();
  b.up = b.right.cross(b.forward);
  return b;
}

// Sutherland–Hodgman against z >= near: a triangle crossing the plane becomes a triangle or a quad. Positions and
// colours are cut linearly in 3D, which is exact before the perspective division.
int clip_near(const ViewVertex in[3], double near, ViewVertex out[4]) {
  int n = 0;
  for (int i = 0; i < 3; ++i) {
    const ViewVertex& a = in[i];
    const ViewVertex& b = in[(i + 1) % 3];
    const bool a_in = a.p.z >= near, b_in = b.p.z >= near;
    if (a_in) out[n++] = a;
    if (a_in != b_in) {
      const double t = (near - a.p.z) / (b.p.z - a.p.z);
      ViewVertex cut;
      cut.p = a.p + (b.p - a.p) * t;
      cut.p.z = near;  // exactly on the plane, whatever the rounding
      for (int c = 0; c < 3; ++c) cut.c[c] = a.c[c] + (b.c[c] - a.c[c]) * t;
      out[n++] = cut;
    }
  }
  return n;
}

double edge(const ScreenVertex& a, const ScreenVertex& b, double px, double py) {
  return (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
}

// The same edge test, evaluated with the endpoints in a fixed order: the two triangles that share an edge then
// get exactly opposite values at every pixel, so a pixel centre on the edge goes to one of them (or both) and
// never falls through the crack between them.
double shared_edge(const ScreenVertex& a, const ScreenVertex& b, double px, double py) {
  const bool in_order = a.x < b.x || (a.x == b.x && a.y < b.y);
  return in_order ? edge(a, b, px, py) : -edge(b, a, px, py);
}

std::uint8_t tone(double b, const RenderOptions& opt) {
  double v = opt.exposure * b;
  v = v > 0 ? std::min(v, 1.0) : 0.0;  // also sends NaN to black
  return static_cast<std::uint8_t>(std::lround(255 * std::pow(v, 1 / opt.gamma)));
}

// Refuses what render() cannot draw: one line naming the argument.
void check_render_args(const Mesh& m, const std::vector<Rgb>& radiosity, int width, int height,
                       const RenderOptions& opt) {
  if (radiosity.size() != m.size())
    throw hpcgi::UsageError("render: " + std::to_string(radiosity.size()) + " radiosity values for " +
                            std::to_string(m.size()) + " patches");
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw hpcgi::UsageError("render: picture size " + std::to_string(width) + "x" + std::to_string(height) +
                            " is not in 1..16384 per side");
  if (!(opt.exposure >= 0) || !std::isfinite(opt.exposure)) throw hpcgi::UsageError("render: exposure must be >= 0");
  if (!(opt.gamma > 0) || !std::isfinite(opt.gamma)) throw hpcgi::UsageError("render: gamma must be > 0");
}

// The linear radiosity at each patch's three corners: its own (flat) or smoothed over its neighbours.
std::vector<std::array<Rgb, 3>> corner_colours(const Mesh& m, const std::vector<Rgb>& radiosity,
                                               const RenderOptions& opt) {
  if (!opt.flat) return smooth_vertex_colours(m, radiosity, opt.crease_deg);
  std::vector<std::array<Rgb, 3>> corner(m.size());
  for (size_t i = 0; i < m.size(); ++i) corner[i] = {radiosity[i], radiosity[i], radiosity[i]};
  return corner;
}

// The screen triangles of one clipped polygon (a fan), those that cover a pixel centre of the picture.
void add_fan(const ScreenVertex* s, int n, int width, int height, std::vector<ScreenTriangle>& tris) {
  for (int k = 1; k + 1 < n; ++k) {
    ScreenTriangle t{{s[0], s[k], s[k + 1]}, 0, 0, 0, 0, 0};
    const double area2 = edge(t.v[0], t.v[1], t.v[2].x, t.v[2].y);
    if (!(std::abs(area2) > 0) || !std::isfinite(area2)) continue;  // edge-on or degenerate: covers no pixel
    t.inv_area2 = 1 / area2;
    const double lo_x = std::min({t.v[0].x, t.v[1].x, t.v[2].x}), hi_x = std::max({t.v[0].x, t.v[1].x, t.v[2].x});
    const double lo_y = std::min({t.v[0].y, t.v[1].y, t.v[2].y}), hi_y = std::max({t.v[0].y, t.v[1].y, t.v[2].y});
    // Pixel (x, y) is sampled at its centre (x + 0.5, y + 0.5).
    t.x0 = static_cast<int>(std::max(0.0, std::ceil(lo_x - 0.5)));
    t.x1 = static_cast<int>(std::min(width - 1.0, std::floor(hi_x - 0.5)));
    t.y0 = static_cast<int>(std::max(0.0, std::ceil(lo_y - 0.5)));
    t.y1 = static_cast<int>(std::min(height - 1.0, std::floor(hi_y - 0.5)));
    if (t.x0 <= t.x1 && t.y0 <= t.y1) tris.push_back(t);
  }
}

// Every patch in camera space, clipped to the near plane and projected to the picture, in mesh order.
std::vector<ScreenTriangle> project_mesh(const Mesh& m, const std::vector<std::array<Rgb, 3>>& corner,
                                         const Camera& cam, const Basis& basis, int width, int height) {
  // The near plane is set by the scene's reach from the eye: far enough that projected coordinates stay within
  // 1e4 focal lengths of the centre, where the edge tests keep their precision; near enough that it cuts only what
  // is 1e4 times closer than the farthest vertex.
  double reach = 0;
  for (const Patch& p : m.patches)
    for (const Vec3& v : p.v) reach = std::max(reach, (v - cam.eye).norm());
  const double near = std::max(reach, 1e-300) * 1e-4;
  const double focal = 0.5 * std::min(width, height) / std::tan(0.5 * cam.fov_deg * kPi / 180);

  std::vector<ScreenTriangle> tris;
  tris.reserve(m.size());
  for (size_t i = 0; i < m.size(); ++i) {
    ViewVertex view[3], clipped[4];
    for (int k = 0; k < 3; ++k) {
      const Vec3 d = m.patches[i].v[k] - cam.eye;
      view[k] = {{d.dot(basis.right), d.dot(basis.up), d.dot(basis.forward)}, corner[i][k]};
    }
    const int n = clip_near(view, near, clipped);
    ScreenVertex s[4];
    for (int k = 0; k < n; ++k) {
      const ViewVertex& v = clipped[k];
      const double w = 1 / v.p.z;
      s[k] = {0.5 * width + focal * v.p.x * w, 0.5 * height - focal * v.p.y * w, w,
              {v.c[0] * w, v.c[1] * w, v.c[2] * w}};
    }
    add_fan(s, n, width, height, tris);
  }
  return tris;
}

// Draws triangle t into rows [b0, b1] of the depth (w = 1/z of the nearest so far; 0 = nothing) and colour buffers.
void draw_rows(const ScreenTriangle& t, int b0, int b1, int width, std::vector<double>& depth,
               std::vector<Rgb>& colour) {
  for (int y = std::max(t.y0, b0); y <= std::min(t.y1, b1); ++y) {
    const double py = y + 0.5;
    for (int x = t.x0; x <= t.x1; ++x) {
      const double px = x + 0.5;
      const double l0 = shared_edge(t.v[1], t.v[2], px, py) * t.inv_area2;
      const double l1 = shared_edge(t.v[2], t.v[0], px, py) * t.inv_area2;
      const double l2 = shared_edge(t.v[0], t.v[1], px, py) * t.inv_area2;
      if (l0 < 0 || l1 < 0 || l2 < 0) continue;
      const double w = l0 * t.v[0].w + l1 * t.v[1].w + l2 * t.v[2].w;
      const size_t at = static_cast<size_t>(y) * width + x;
      if (!(w > depth[at])) continue;
      depth[at] = w;
      for (int c = 0; c < 3; ++c) colour[at][c] = (l0 * t.v[0].cw[c] + l1 * t.v[1].cw[c] + l2 * t.v[2].cw[c]) / w;
    }
  }
}

}  // namespace

Image render(const Mesh& m, const std::vector<Rgb>& radiosity, const Camera& cam, int width, int height,
             const RenderOptions& opt) {
  check_render_args(m, radiosity, width, height, opt);
  const Basis basis = camera_basis(cam);
  const std::vector<ScreenTriangle> tris =
      project_mesh(m, corner_colours(m, radiosity, opt), cam, basis, width, height);

  Image img;
  img.width = width;
  img.height = height;
  img.rgb.assign(3 * static_cast<size_t>(width) * height, 0);
  std::vector<double> depth(static_cast<size_t>(width) * height, 0);  // w = 1/z of the nearest so far; 0 = nothing
  std::vector<Rgb> colour(static_cast<size_t>(width) * height, Rgb{0, 0, 0});

  // Each thread owns bands of rows and draws every triangle into them in mesh order, so the picture does not
  // depend on the number of threads, and a nearer triangle wins whatever the order (ties go to the first drawn).
  const int band = 8;
#pragma omp parallel for schedule(dynamic)
  for (int b0 = 0; b0 < height; b0 += band) {
    const int b1 = std::min(height, b0 + band) - 1;
    for (const ScreenTriangle& t : tris)
      if (t.y1 >= b0 && t.y0 <= b1) draw_rows(t, b0, b1, width, depth, colour);
  }

#pragma omp parallel for schedule(static)
  for (size_t at = 0; at < depth.size(); ++at)
    for (int c = 0; c < 3; ++c) img.rgb[3 * at + c] = depth[at] > 0 ? tone(colour[at][c], opt) : 0;
  return img;
}

}  // namespace radiosity
