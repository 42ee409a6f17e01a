// Meshes whose form factors are known in closed form (Howell's catalogue of radiation configuration factors), cut
// into many small triangles so that the hemicube, which works patch by patch, can be checked against them:
//   two_facing_squares    unit squares facing each other at distance 1          (Howell C-11: 0.199825)
//   perpendicular_squares unit squares at a right angle sharing an edge         (Howell C-14: 0.200044)
//   coaxial_disks         disks of radius 1 facing each other at distance 1     (Howell C-41: 0.381966)
//   closed_unit_cube      six inward-facing faces: every row of F must sum to 1 (nothing escapes an enclosure)
// Header-only on purpose: the form-factor tests link no scene/ sources.
#pragma once
#include <cmath>
#include <string>

#include "common/errors.hpp"
#include "radiosity/mesh.hpp"

namespace radiosity {

namespace analytic_detail {

inline void require_cells(int k, const char* what) {
  if (k < 1) throw hpcgi::UsageError(std::string(what) + " must be >= 1, got " + std::to_string(k));
}

// Adds the parallelogram origin + s·du + t·dv, s, t in [0, 1], as k × k cells of two triangles each; the fronts
// face du × dv. The patches belong to the mesh's last entity.
inline void add_grid(Mesh& m, const Vec3& origin, const Vec3& du, const Vec3& dv, int k, const Rgb& reflectivity,
                     const Rgb& emission) {
  const int entity = static_cast<int>(m.entities.size()) - 1;
  auto at = [&](int a, int b) { return origin + du * (double(a) / k) + dv * (double(b) / k); };
  for (int b = 0; b < k; ++b)
    for (int a = 0; a < k; ++a) {
      const Vec3 p00 = at(a, b), p10 = at(a + 1, b), p01 = at(a, b + 1), p11 = at(a + 1, b + 1);
      for (const auto& tri : {std::array<Vec3, 3>{p00, p10, p11}, std::array<Vec3, 3>{p00, p11, p01}}) {
        Patch p;
        p.v = tri;
        p.reflectivity = reflectivity;
        p.emission = emission;
        p.entity = entity;
        m.patches.push_back(p);
      }
    }
}

// A disk of radius 1 in the plane z = height, centred on the z axis, facing +z (up) or -z: a fan of `segments`
// triangles around the centre, then rings - 1 annuli of 2·segments triangles, so every patch spans 1/rings in
// radius. The polygon is inscribed in the circle: its area falls short of π by 1 - sin(2π/s)·s/(2π) (0.16% at
// s = 64), a geometric error of the mesh, not of the hemicube.
inline void add_disk(Mesh& m, double height, bool up, int rings, int segments) {
  const int entity = static_cast<int>(m.entities.size()) - 1;
  auto at = [&](int ring, int seg) {
    // seg % segments: the last triangle of a ring reuses the first vertex bit for bit, so the ring closes.
    const double r = double(ring) / rings, phi = 2 * M_PI * (seg % segments) / segments;
    return Vec3{r * std::cos(phi), r * std::sin(phi), height};
  };
  auto add = [&](Vec3 a, Vec3 b, Vec3 c) {
    Patch p;
    p.v = up ? std::array<Vec3, 3>{a, b, c} : std::array<Vec3, 3>{a, c, b};  // counter-clockwise seen from +z
    p.entity = entity;
    m.patches.push_back(p);
  };
  for (int s = 0; s < segments; ++s) add(at(0, 0), at(1, s), at(1, s + 1));
  for (int ring = 1; ring < rings; ++ring)
    for (int s = 0; s < segments; ++s) {
      add(at(ring, s), at(ring + 1, s), at(ring + 1, s + 1));
      add(at(ring, s), at(ring + 1, s + 1), at(ring, s + 1));
    }
}

}  // namespace analytic_detail

// Square 1: [0,1]² in z = 0 facing +z; square 2: [0,1]² in z = 1 facing -z. Entities "square1", "square2";
// 2·k² patches each, square 1's first.
inline Mesh two_facing_squares(int k) {
  analytic_detail::require_cells(k, "cells per side");
  Mesh m;
  m.entities = {"square1"};
  analytic_detail::add_grid(m, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, k, {0, 0, 0}, {0, 0, 0});
  m.entities.push_back("square2");
  analytic_detail::add_grid(m, {0, 0, 1}, {0, 1, 0}, {1, 0, 0}, k, {0, 0, 0}, {0, 0, 0});
  return m;
}

// Square 1: [0,1]² in z = 0 facing +z; square 2: y, z in [0,1] in x = 0 facing +x; they share the edge x = z = 0.
inline Mesh perpendicular_squares(int k) {
  analytic_detail::require_cells(k, "cells per side");
  Mesh m;
  m.entities = {"square1"};
  analytic_detail::add_grid(m, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, k, {0, 0, 0}, {0, 0, 0});
  m.entities.push_back("square2");
  analytic_detail::add_grid(m, {0, 0, 0}, {0, 1, 0}, {0, 0, 1}, k, {0, 0, 0}, {0, 0, 0});
  return m;
}

// Disk 1 in z = 0 facing +z, disk 2 in z = 1 facing -z, both of radius 1 on the z axis; segments·(2·rings - 1)
// patches each. Entities "disk1", "disk2".
inline Mesh coaxial_disks(int rings, int segments) {
  analytic_detail::require_cells(rings, "rings");
  if (segments < 3) throw hpcgi::UsageError("segments must be >= 3, got " + std::to_string(segments));
  Mesh m;
  m.entities = {"disk1"};
  analytic_detail::add_disk(m, 0, true, rings, segments);
  m.entities.push_back("disk2");
  analytic_detail::add_disk(m, 1, false, rings, segments);
  return m;
}

// The cube [0,1]³ with its six faces facing inward, k × k cells of two triangles per face, uniform ρ and E.
// Entities "x0", "x1", "y0", "y1", "z0", "z1" (the face at x = 0, x = 1, ...).
inline Mesh closed_unit_cube(int k, const Rgb& reflectivity, const Rgb& emission) {
  analytic_detail::require_cells(k, "cells per side");
  struct Face {
    const char* name;
    Vec3 origin, du, dv;  // du × dv points into the cube
  };
  const Face faces[] = {
      {"x0", {0, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {"x1", {1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
      {"y0", {0, 0, 0}, {0, 0, 1}, {1, 0, 0}}, {"y1", {0, 1, 0}, {1, 0, 0}, {0, 0, 1}},
      {"z0", {0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {"z1", {0, 0, 1}, {0, 1, 0}, {1, 0, 0}},
  };
  Mesh m;
  for (const Face& f : faces) {
    m.entities.push_back(f.name);
    analytic_detail::add_grid(m, f.origin, f.du, f.dv, k, reflectivity, emission);
  }
  return m;
}

}  // namespace radiosity
