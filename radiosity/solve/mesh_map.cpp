#include "radiosity/solve/mesh_map.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/errors.hpp"

namespace radiosity {
namespace {

// How far inside triangle t the point p is: the smallest barycentric coordinate of p's projection on t's plane
// (negative outside), or -1 when p is off the plane by more than a rounding margin.
double inside(const Patch& t, const Vec3& p) {
  const Vec3 e1 = t.v[1] - t.v[0], e2 = t.v[2] - t.v[0], d = p - t.v[0];
  const Vec3 nrm = e1.cross(e2);
  const double nn = nrm.dot(nrm);
  if (!(nn > 0)) return -1;
  const double size = std::sqrt(std::max(e1.dot(e1), e2.dot(e2)));
  if (std::abs(d.dot(nrm)) / std::sqrt(nn) > 1e-9 * size) return -1;
  const double b1 = d.cross(e2).dot(nrm) / nn, b2 = e1.cross(d).dot(nrm) / nn;
  return std::min({1 - b1 - b2, b1, b2});
}

}  // namespace

std::vector<size_t> containing_patches(const Mesh& coarse, const Mesh& fine) {
  std::vector<std::vector<size_t>> by_entity;
  for (size_t I = 0; I < coarse.size(); ++I) {
    const size_t e = static_cast<size_t>(coarse.patches[I].entity);
    if (by_entity.size() <= e) by_entity.resize(e + 1);
    by_entity[e].push_back(I);
  }
  std::vector<size_t> owner(fine.size(), 0);
  std::vector<char> found(fine.size(), 0);
#pragma omp parallel for schedule(dynamic, 64)
  for (size_t i = 0; i < fine.size(); ++i) {
    const Patch& f = fine.patches[i];
    const size_t e = static_cast<size_t>(f.entity);
    if (e >= by_entity.size()) continue;
    const Vec3 c = f.centroid();
    double best = -1e-9;  // a centroid may sit on an edge only by rounding: it is strictly inside its parent
    for (size_t I : by_entity[e]) {
      const double b = inside(coarse.patches[I], c);
      if (b > best) {
        best = b;
        owner[i] = I;
        found[i] = 1;
      }
    }
  }
  std::vector<double> area(coarse.size(), 0.0);
  for (size_t i = 0; i < fine.size(); ++i) {
    if (!found[i])
      throw hpcgi::UsageError("the reference mesh is not a refinement of this mesh: its patch " + std::to_string(i) +
                              " lies in no patch of this mesh (same scene, smaller --divide?)");
    area[owner[i]] += fine.patches[i].area();
  }
  for (size_t I = 0; I < coarse.size(); ++I) {
    const double a = coarse.patches[I].area();
    if (!(std::abs(area[I] - a) <= 1e-6 * a))
      throw hpcgi::UsageError("the reference mesh is not a refinement of this mesh: its patches in patch " +
                              std::to_string(I) + " cover " + std::to_string(area[I]) + " of its area " +
                              std::to_string(a));
  }
  return owner;
}

std::vector<Rgb> area_weighted_onto(const Mesh& coarse, const Mesh& fine, const std::vector<Rgb>& fine_B) {
  if (fine_B.size() != fine.size()) throw hpcgi::UsageError("area_weighted_onto: a radiosity of the wrong size");
  const std::vector<size_t> owner = containing_patches(coarse, fine);
  std::vector<Rgb> sum(coarse.size(), Rgb{0, 0, 0});
  std::vector<double> area(coarse.size(), 0.0);
  for (size_t i = 0; i < fine.size(); ++i) {
    const double a = fine.patches[i].area();
    area[owner[i]] += a;
    for (int c = 0; c < 3; ++c) sum[owner[i]][c] += a * fine_B[i][c];
  }
  for (size_t I = 0; I < coarse.size(); ++I)
    for (int c = 0; c < 3; ++c) sum[I][c] /= area[I];
  return sum;
}

}  // namespace radiosity
