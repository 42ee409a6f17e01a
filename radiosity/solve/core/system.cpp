#include "radiosity/solve/core/system.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/errors.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/storage/half.hpp"

namespace radiosity {

std::vector<Rgb> rrv_initial_radiosity(const std::vector<Rgb>& attribute, const std::vector<Rgb>& emission) {
  if (attribute.size() != emission.size())
    throw hpcgi::UsageError("initial radiosity: " + std::to_string(attribute.size()) + " radiosity attributes for " +
                            std::to_string(emission.size()) + " emissions");
  std::vector<Rgb> b0(attribute.size());
  for (size_t i = 0; i < b0.size(); ++i)
    for (int c = 0; c < 3; ++c) b0[i][c] = std::max(attribute[i][c], emission[i][c]);
  return b0;
}

System make_system(const Mesh& mesh, const float* F) { return make_system(mesh, dense_float32_view(F, mesh.size())); }

System make_system(const Mesh& mesh, const FFMatrixView& F) {
  System s;
  s.n = mesh.size();
  s.matrix = F;
  std::vector<Rgb> attribute;
  for (const Patch& p : mesh.patches) {
    s.emission.push_back(p.emission);
    s.reflectivity.push_back(p.reflectivity);
    attribute.push_back(p.radiosity);
  }
  s.initial = rrv_initial_radiosity(attribute, s.emission);
  return s;
}

bool is_grey(const System& sys) {
  auto grey = [](const Rgb& v) { return v[0] == v[1] && v[1] == v[2]; };
  return std::all_of(sys.emission.begin(), sys.emission.end(), grey) &&
         std::all_of(sys.reflectivity.begin(), sys.reflectivity.end(), grey) &&
         std::all_of(sys.initial.begin(), sys.initial.end(), grey);
}

void check_system(const System& sys) {
  if (sys.n == 0) throw hpcgi::UsageError("radiosity system: no patches");
  if (!sys.matrix.n || (sys.matrix.storage == FFStorage::dense && !sys.matrix.data)) throw hpcgi::UsageError("radiosity system: no form-factor matrix");
  if (sys.rows_end != SIZE_MAX && (sys.rows_begin > sys.rows_end || sys.rows_end > sys.n))
    throw hpcgi::UsageError("radiosity system: rows " + std::to_string(sys.rows_begin) + ".." +
                            std::to_string(sys.rows_end) + " of F for " + std::to_string(sys.n) + " patches");
  if (sys.matrix.n != sys.n)
    throw hpcgi::UsageError("radiosity system: a form-factor matrix of " + std::to_string(sys.matrix.n) +
                            " patches for " + std::to_string(sys.n));
  auto check = [&](const std::vector<Rgb>& v, const char* what) {
    if (v.size() != sys.n)
      throw hpcgi::UsageError(std::string("radiosity system: ") + std::to_string(v.size()) + " " + what +
                              " values for " + std::to_string(sys.n) + " patches");
  };
  check(sys.emission, "emission");
  check(sys.reflectivity, "reflectivity");
  check(sys.initial, "initial radiosity");
}

Rgb emission_norm2(const System& sys) {
  Rgb e2{0, 0, 0};
  for (const Rgb& e : sys.emission)
    for (int c = 0; c < 3; ++c) e2[c] += e[c] * e[c];
  return e2;
}

Rgb residual_scale(const System& sys) {
  const Rgb e2 = emission_norm2(sys);
  Rgb scale;
  for (int c = 0; c < 3; ++c) scale[c] = e2[c] == 0 ? 1.0 : std::sqrt(e2[c]);  // a NaN in E stays NaN
  return scale;
}

namespace {

// Σ_j F_ij B_j per channel in double, for row i of any storage.
template <class Get>
Rgb row_product(const FFMatrixView& F, Get get, size_t i, const std::vector<Rgb>& B) {
  double s0 = 0, s1 = 0, s2 = 0;
  auto add = [&](size_t k, size_t j) {
    const double f = get(k);
    s0 += f * B[j][0];
    s1 += f * B[j][1];
    s2 += f * B[j][2];
  };
  if (F.storage != FFStorage::dense)
    for_each_entry(F, i, add);
  else
    for (size_t j = 0; j < F.n; ++j) add(i * F.n + j, j);
  return {s0 * F.scale, s1 * F.scale, s2 * F.scale};
}

}  // namespace

Rgb residual_squares(const System& sys, const std::vector<Rgb>& B) {
  check_system(sys);
  if (B.size() != sys.n) throw hpcgi::UsageError("relative_residual: B has the wrong size");
  const size_t first = holds_all_rows(sys) ? 0 : sys.rows_begin, last = holds_all_rows(sys) ? sys.n : sys.rows_end;
  const FFMatrixView F = system_matrix(sys);
  const auto* f32 = static_cast<const float*>(F.data);
  const auto* u16 = static_cast<const uint16_t*>(F.data);
  double r0 = 0, r1 = 0, r2 = 0;
#pragma omp parallel for schedule(static) reduction(+ : r0, r1, r2)
  for (size_t i = first; i < last; ++i) {
    const Rgb& rho = sys.reflectivity[i];
    // Row i of F as the system holds it: a dense block from its first row on, a sparse matrix by every row.
    const size_t local = F.storage == FFStorage::dense ? i - first : i;
    Rgb s{0, 0, 0};
    if (row_needed(rho)) {  // a patch with reflectivity 0 takes nothing from F (B_i = E_i)
      switch (F.values) {
        case FFValues::float32: s = row_product(F, [&](size_t k) { return f32[k]; }, local, B); break;
        case FFValues::float16: s = row_product(F, [&](size_t k) { return half_to_float(u16[k]); }, local, B); break;
        case FFValues::bfloat16:
          s = row_product(F, [&](size_t k) { return bfloat16_to_float(u16[k]); }, local, B);
          break;
      }
    }
    const Rgb& e = sys.emission[i];
    const double d0 = e[0] - (B[i][0] - rho[0] * s[0]);
    const double d1 = e[1] - (B[i][1] - rho[1] * s[1]);
    const double d2 = e[2] - (B[i][2] - rho[2] * s[2]);
    r0 += d0 * d0;
    r1 += d1 * d1;
    r2 += d2 * d2;
  }
  return {r0, r1, r2};
}

Rgb relative_residual(const System& sys, const std::vector<Rgb>& B) {
  if (!holds_all_rows(sys))
    throw hpcgi::UsageError("relative_residual: the system holds only rows " + std::to_string(sys.rows_begin) + ".." +
                            std::to_string(sys.rows_end) + " of F (a rank's share)");
  const Rgb r2 = residual_squares(sys, B);
  const Rgb scale = residual_scale(sys);
  return {std::sqrt(r2[0]) / scale[0], std::sqrt(r2[1]) / scale[1], std::sqrt(r2[2]) / scale[2]};
}

}  // namespace radiosity
