#include "radiosity/solve/system.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/errors.hpp"

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

System make_system(const Mesh& mesh, const float* F) {
  System s;
  s.n = mesh.size();
  s.F = F;
  std::vector<Rgb> attribute;
  for (const Patch& p : mesh.patches) {
    s.emission.push_back(p.emission);
    s.reflectivity.push_back(p.reflectivity);
    attribute.push_back(p.radiosity);
  }
  s.initial = rrv_initial_radiosity(attribute, s.emission);
  return s;
}

void check_system(const System& sys) {
  if (sys.n == 0) throw hpcgi::UsageError("radiosity system: no patches");
  if (!sys.F) throw hpcgi::UsageError("radiosity system: no form-factor matrix");
  auto check = [&](const std::vector<Rgb>& v, const char* what) {
    if (v.size() != sys.n)
      throw hpcgi::UsageError(std::string("radiosity system: ") + std::to_string(v.size()) + " " + what +
                              " values for " + std::to_string(sys.n) + " patches");
  };
  check(sys.emission, "emission");
  check(sys.reflectivity, "reflectivity");
  check(sys.initial, "initial radiosity");
}

Rgb residual_scale(const System& sys) {
  Rgb e2{0, 0, 0};
  for (const Rgb& e : sys.emission)
    for (int c = 0; c < 3; ++c) e2[c] += e[c] * e[c];
  Rgb scale;
  for (int c = 0; c < 3; ++c) scale[c] = e2[c] == 0 ? 1.0 : std::sqrt(e2[c]);  // a NaN in E stays NaN
  return scale;
}

Rgb relative_residual(const System& sys, const std::vector<Rgb>& B) {
  check_system(sys);
  if (B.size() != sys.n) throw hpcgi::UsageError("relative_residual: B has the wrong size");
  const size_t n = sys.n;
  double r0 = 0, r1 = 0, r2 = 0;
#pragma omp parallel for schedule(static) reduction(+ : r0, r1, r2)
  for (size_t i = 0; i < n; ++i) {
    const float* Fi = sys.F + i * n;
    double s0 = 0, s1 = 0, s2 = 0;
    for (size_t j = 0; j < n; ++j) {
      const double f = Fi[j];
      s0 += f * B[j][0];
      s1 += f * B[j][1];
      s2 += f * B[j][2];
    }
    const Rgb& e = sys.emission[i];
    const Rgb& rho = sys.reflectivity[i];
    const double d0 = e[0] - (B[i][0] - rho[0] * s0);
    const double d1 = e[1] - (B[i][1] - rho[1] * s1);
    const double d2 = e[2] - (B[i][2] - rho[2] * s2);
    r0 += d0 * d0;
    r1 += d1 * d1;
    r2 += d2 * d2;
  }
  const Rgb scale = residual_scale(sys);
  return {std::sqrt(r0) / scale[0], std::sqrt(r1) / scale[1], std::sqrt(r2) / scale[2]};
}

}  // namespace radiosity
