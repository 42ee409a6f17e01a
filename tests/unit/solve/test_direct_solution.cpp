// Jacobi and BiCG-STAB against the dense direct solution, on random systems with row and column sums of F < 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "radiosity/solve/solve.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

double max_of(const Rgb& v) { return std::max({v[0], v[1], v[2]}); }

SolveConfig config(const std::string& method, const std::string& backend, const std::string& layout,
                   const std::string& precision, double tol) {
  SolveConfig c = solve_config(backend, layout, method, precision);
  c.tol = tol;
  c.max_iter = 5000;
  return c;
}

}  // namespace

// ‖b - b*‖ ≤ ‖A⁻¹‖ ‖e - A b‖ and ‖e‖ ≤ ‖A‖ ‖b*‖, with ‖A⁻¹‖₂ ≤ 1/(1-q), ‖A‖₂ ≤ 1+q, q ≥ ‖ρF‖₂: a relative
// residual r guarantees a relative error of at most r (1+q)/(1-q). Every method, backend and layout in double.
TEST(DirectSolution, EveryDenseCombinationConvergesToIt) {
  const double tol = 1e-8;
  for (unsigned seed : {1u, 2u, 3u}) {
    const Problem p = random_problem(50, seed);
    const std::vector<Rgb> exact = direct_solve(p.sys);
    const double q = norm2_bound(p.sys);
    ASSERT_LT(q, 0.9);
    for (const char* method : {"jacobi", "bicgstab"})
      for (const char* backend : {"serial", "openmp"})
        for (const char* layout : {"aos", "soa"}) {
          SCOPED_TRACE(std::string(method) + " " + backend + " " + layout + " seed " + std::to_string(seed));
          const SolveResult r = solve(p.sys, config(method, backend, layout, "double", tol));
          EXPECT_EQ(r.status, SolveStatus::converged) << r.detail;
          EXPECT_LE(max_of(r.rel_residual), tol);
          EXPECT_LE(rel_diff(r.B, exact), max_of(r.rel_residual) * (1 + q) / (1 - q) + 1e-14);
          EXPECT_LE(rel_diff(r.B, exact), tol * (1 + q) / (1 - q));
        }
  }
}

TEST(DirectSolution, JacobiAndBicgstabAgreeWithinTheTolerance) {
  const double tol = 1e-8;
  const Problem p = random_problem(80, 7);
  const double q = norm2_bound(p.sys);
  const SolveResult j = solve(p.sys, config("jacobi", "serial", "aos", "double", tol));
  const SolveResult b = solve(p.sys, config("bicgstab", "serial", "aos", "double", tol));
  ASSERT_EQ(j.status, SolveStatus::converged);
  ASSERT_EQ(b.status, SolveStatus::converged);
  EXPECT_LE(rel_diff(j.B, b.B), 2 * tol * (1 + q) / (1 - q));
}

// In float, at the report's tolerance 1e-6. The method measures its residual in float, the result's residual is
// recomputed in double, so the two may differ by float's rounding: allow the recomputed one 2·tol.
TEST(DirectSolution, FloatReachesTheReportsTolerance) {
  const double tol = 1e-6;
  const Problem p = random_problem(50, 11);
  const std::vector<Rgb> exact = direct_solve(p.sys);
  const double q = norm2_bound(p.sys);
  for (const char* method : {"jacobi", "bicgstab"})
    for (const char* layout : {"aos", "soa"}) {
      SCOPED_TRACE(std::string(method) + " " + layout);
      const SolveResult r = solve(p.sys, config(method, "openmp", layout, "float", tol));
      EXPECT_EQ(r.status, SolveStatus::converged) << r.detail;
      EXPECT_LE(max_of(r.rel_residual), 2 * tol);
      EXPECT_LE(rel_diff(r.B, exact), max_of(r.rel_residual) * (1 + q) / (1 - q) + 1e-7);
    }
}

// A channel without any emission has b_c = 0 and is measured by its absolute residual ‖A_c b_c‖₂.
TEST(DirectSolution, ChannelWithoutEmissionGoesToZero) {
  Problem p = random_problem(50, 5);
  for (Rgb& e : p.sys.emission) e[2] = 0;  // no blue light; B0 keeps its random blue attribute
  for (const char* method : {"jacobi", "bicgstab"}) {
    SCOPED_TRACE(method);
    const SolveResult r = solve(p.sys, config(method, "serial", "aos", "double", 1e-10));
    ASSERT_EQ(r.status, SolveStatus::converged) << r.detail;
    EXPECT_LE(r.rel_residual[2], 1e-10);
    double blue = 0;
    for (const Rgb& b : r.B) blue = std::max(blue, std::abs(b[2]));
    EXPECT_LE(blue, 1e-9);
  }
}

TEST(DirectSolution, RelativeResidualIsTheDefinedOne) {
  Problem p = random_problem(40, 9);
  for (Rgb& e : p.sys.emission) e[1] = 0;
  const std::vector<Rgb> zero(p.sys.n, Rgb{0, 0, 0});
  const Rgb r0 = relative_residual(p.sys, zero);  // e - A·0 = e: 1 where e ≠ 0, and ‖A·0‖ = 0 where e = 0
  EXPECT_DOUBLE_EQ(r0[0], 1.0);
  EXPECT_DOUBLE_EQ(r0[1], 0.0);
  EXPECT_DOUBLE_EQ(r0[2], 1.0);
  EXPECT_LE(max_of(relative_residual(p.sys, direct_solve(p.sys))), 1e-14);
}
