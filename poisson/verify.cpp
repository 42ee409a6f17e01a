// The float64 check of bin/poisson's answer (verify.hpp).
#include "poisson/verify.hpp"

#include <cmath>
#include <cstdlib>

#include "common/errors.hpp"
#include "poisson/config/problem.hpp"

namespace poisson {

double rhs_norm2(long n) {
  // b_ij = -2 pi^2 h^2 (c_i S_j + S_i c_j) with S = sin^2(pi x), c = cos(2 pi x), so
  // sum b^2 = 4 pi^4 h^4 (2 (sum c^2)(sum S^2) + 2 (sum c S)^2).
  const GridTable g{Grid{n}};
  double cc = 0, ss = 0, cs = 0;
  for (long i = 0; i < n; ++i) {
    const double S = g.s[i] * g.s[i], c = g.c2[i];
    cc += c * c;
    ss += S * S;
    cs += c * S;
  }
  const double sum = 4 * std::pow(kPi, 4) * g.hh * g.hh * (2 * cc * ss + 2 * cs * cs);
  return std::sqrt(std::max(sum, 0.0));
}

namespace {
double test_factor() {
  const char* env = std::getenv("HPCGI_TEST_POISSON_BOUND");
  if (!env || !*env) return 1.0;
  char* end = nullptr;
  const double f = std::strtod(env, &end);
  if (end == env || *end || !(f > 0.0 && f <= 1.0))
    throw hpcgi::UsageError(std::string("HPCGI_TEST_POISSON_BOUND='") + env + "' is not a factor in (0, 1]");
  return f;
}
}  // namespace

Check check_answer(long n, double rho, double eps, double error_inf) {
  Check c;
  const double h = 1.0 / static_cast<double>(n + 1), sh = std::sin(kPi * h / 2);
  c.error_inf = error_inf;
  c.discretisation = std::pow(kPi, 4) * h * h / 6;
  c.algebraic = rho * rhs_norm2(n) / (8 * sh * sh);
  c.rounding = eps;
  c.test_factor = test_factor();
  c.bound = (c.discretisation + c.algebraic + c.rounding) * c.test_factor;
  c.agreed = std::isfinite(error_inf) && error_inf <= c.bound;
  return c;
}

}  // namespace poisson
