// References for the form-factor tests, none of them computed by a hemicube:
//  - closed forms from Howell's "A Catalog of Radiation Heat Transfer Configuration Factors" (B-3, C-11, C-14,
//    C-41);
//  - the exact form factor from a point to a polygon (Lambert's contour formula, as used for analytic form factors
//    by Baum, Rushmeier & Winget 1989): F = (1/2π) Σ_edges γ_k n·(R_k × R_k+1)/|R_k × R_k+1|, γ_k the angle the
//    edge subtends. The hemicube measures exactly this, from the centroid of patch i, as R grows; the area-weighted
//    sum of it over the patches of a surface is what the hemicube converges to on a given mesh.
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"

namespace fftest {

using radiosity::FormFactors;
using radiosity::Mesh;
using radiosity::Patch;
using radiosity::Vec3;

// Howell B-3: from a point to a parallel rectangle a × b at distance c, the point on the normal through a corner.
inline double howell_point_to_parallel_rectangle_corner(double a, double b, double c) {
  const double X = a / c, Y = b / c, sx = std::sqrt(1 + X * X), sy = std::sqrt(1 + Y * Y);
  return (X / sx * std::atan(Y / sx) + Y / sy * std::atan(X / sy)) / (2 * M_PI);
}

// Howell C-11: between directly opposed parallel rectangles a × b at distance c.
inline double howell_parallel_rectangles(double a, double b, double c) {
  const double X = a / c, Y = b / c, sx = std::sqrt(1 + X * X), sy = std::sqrt(1 + Y * Y);
  return 2 / (M_PI * X * Y) *
         (0.5 * std::log((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y)) + X * sy * std::atan(X / sy) +
          Y * sx * std::atan(Y / sx) - X * std::atan(X) - Y * std::atan(Y));
}

// Howell C-14: from a rectangle of width w to a perpendicular rectangle of height h sharing its edge of length l.
inline double howell_perpendicular_rectangles(double w, double h, double l) {
  const double W = w / l, H = h / l, A = W * W + H * H;
  const double t1 = (1 + W * W) * (1 + H * H) / (1 + A);
  const double t2 = std::pow(W * W * (1 + A) / ((1 + W * W) * A), W * W);
  const double t3 = std::pow(H * H * (1 + A) / ((1 + H * H) * A), H * H);
  return 1 / (M_PI * W) *
         (W * std::atan(1 / W) + H * std::atan(1 / H) - std::sqrt(A) * std::atan(1 / std::sqrt(A)) +
          0.25 * std::log(t1 * t2 * t3));
}

// Howell C-41: from a disk of radius r1 to a coaxial parallel disk of radius r2 at distance h.
inline double howell_coaxial_disks(double r1, double r2, double h) {
  const double R1 = r1 / h, R2 = r2 / h, X = 1 + (1 + R2 * R2) / (R1 * R1);
  return 0.5 * (X - std::sqrt(X * X - 4 * (R2 / R1) * (R2 / R1)));
}

// Exact form factor from the point p with unit normal n to the triangle t, which must lie on the front side of p's
// plane (touching it is allowed). No occlusion.
inline double point_to_triangle(const Vec3& p, const Vec3& n, const Patch& t) {
  double sum = 0;
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = (t.v[k] - p).normalized(), b = (t.v[(k + 1) % 3] - p).normalized(), c = a.cross(b);
    const double cn = c.norm();
    if (cn == 0) continue;
    sum += std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * n.dot(c) / cn;
  }
  return std::abs(sum) / (2 * M_PI);
}

// The matrix the hemicube converges to as R grows on a scene without occlusion: entry (i, j) is the exact form
// factor from patch i's centroid to patch j.
inline FormFactors centroid_form_factors(const Mesh& m) {
  FormFactors L;
  L.n = m.size();
  L.values.assign(L.n * L.n, 0.0f);
  for (size_t i = 0; i < L.n; ++i) {
    const Vec3 c = m.patches[i].centroid(), n = m.patches[i].normal();
    for (size_t j = 0; j < L.n; ++j)
      if (j != i) L.values[i * L.n + j] = static_cast<float>(point_to_triangle(c, n, m.patches[j]));
  }
  return L;
}

// F from entity e1 to entity e2 as the area-weighted sum over e1's patches: Σ_i∈e1 A_i Σ_j∈e2 F_ij / Σ_i∈e1 A_i.
inline double entity_form_factor(const Mesh& m, const FormFactors& F, int e1, int e2) {
  double num = 0, area = 0;
  for (size_t i = 0; i < m.size(); ++i) {
    if (m.patches[i].entity != e1) continue;
    double s = 0;
    for (size_t j = 0; j < m.size(); ++j)
      if (m.patches[j].entity == e2) s += F(i, j);
    num += m.patches[i].area() * s;
    area += m.patches[i].area();
  }
  return num / area;
}

inline double entity_area(const Mesh& m, int e) {
  double a = 0;
  for (const Patch& p : m.patches)
    if (p.entity == e) a += p.area();
  return a;
}

}  // namespace fftest
