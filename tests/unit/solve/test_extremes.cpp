// The solvers at the edges of their range, on closed rooms whose answer is known (reference.hpp's closed_problem:
// F_ij = 1/(n-1), rows summing to exactly 1, so uniform ρ and E give B = E/(1-ρ) everywhere).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "radiosity/solve/solve.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

constexpr size_t kN = 33;

Problem uniform_room(double rho, double E) {
  return closed_problem(kN, std::vector<Rgb>(kN, Rgb{rho, rho, rho}), std::vector<Rgb>(kN, Rgb{E, E, E}));
}

double max_rel_error(const std::vector<Rgb>& B, double exact) {
  double worst = 0;
  for (const Rgb& b : B)
    for (double x : b) worst = std::max(worst, std::abs(x - exact) / exact);
  return worst;
}

}  // namespace

// From B0 = E, Jacobi's iterate k is E (1 - ρ^(k+1)) / (1 - ρ): its relative error and the residual it stops on
// are both ρ^(k+1), so it stops after about log(tol) / log(ρ) steps with an error of at most tol. The issue's
// test is ρ = 0.99; 0.9 ... 0.9999 show the step count growing as 1 / (1 - ρ).
TEST(Extremes, ClosedBoxConvergesToEOverOneMinusRhoWithinTheTolerance) {
  const double tol = 1e-6;
  for (double rho : {0.9, 0.99, 0.999, 0.9999}) {
    SCOPED_TRACE(rho);
    const Problem p = uniform_room(rho, 1.0);
    SolveConfig c;
    c.precision = Precision::double_;
    c.tol = tol;
    c.max_iter = 200000;
    const SolveResult r = solve(p.sys, c);
    ASSERT_EQ(r.status, SolveStatus::converged);
    const double steps = std::log(tol) / std::log(rho);
    EXPECT_GE(double(r.iterations), steps - 2);
    EXPECT_LE(double(r.iterations), steps + 1);
    EXPECT_LE(max_rel_error(r.B, 1.0 / (1 - rho)), tol);
  }
}

// BiCG-STAB does not care how close ρ is to 1 on this room: its matrix has two distinct eigenvalues.
TEST(Extremes, BicgstabSolvesTheNearlyLosslessBoxInAFewIterations) {
  const Problem p = uniform_room(0.9999, 1.0);
  SolveConfig c;
  c.method = Method::bicgstab;
  c.precision = Precision::double_;
  c.tol = 1e-10;
  const SolveResult r = solve(p.sys, c);
  ASSERT_EQ(r.status, SolveStatus::converged) << r.detail;
  EXPECT_LE(r.iterations, 5);
  EXPECT_LE(max_rel_error(r.B, 1e4), 1e-9);
}

// No light: B = 0 solves it, and the residual is measured absolutely (residual_scale is 1), so it is 0, not 0/0.
TEST(Extremes, ZeroEmissionHasADefinedResidual) {
  const Problem p = uniform_room(0.5, 0.0);
  for (const char* method : {"jacobi", "bicgstab"}) {
    SolveConfig c;
    c.method = parse_method(method);
    const SolveResult r = solve(p.sys, c);
    EXPECT_EQ(r.status, SolveStatus::converged) << method;
    EXPECT_EQ(r.iterations, 0) << method;
    for (double x : r.rel_residual) EXPECT_EQ(x, 0.0);
    for (const Rgb& b : r.B) EXPECT_EQ(b, (Rgb{0, 0, 0}));
  }
}

// Float's range: E = 1e30 gives B = 2e30 (its squares, 4e60, are summed in double), E = 1e-30 gives B = 2e-30
// with products F B of 6e-32, still normal floats (the least is 1.2e-38). Both converge to the relative accuracy
// of E = 1. (1e39, beyond float, is test_guards.cpp's nonfinite case.)
TEST(Extremes, FloatHandlesEmissionFrom1em30To1e30) {
  for (double E : {1e30, 1.0, 1e-30}) {
    SCOPED_TRACE(E);
    const Problem p = uniform_room(0.5, E);
    for (const char* method : {"jacobi", "bicgstab"}) {
      SolveConfig c;
      c.method = parse_method(method);
      c.tol = 1e-6;
      const SolveResult r = solve(p.sys, c);
      ASSERT_EQ(r.status, SolveStatus::converged) << method;
      EXPECT_LE(max_rel_error(r.B, 2 * E), 3e-6) << method;
    }
  }
}
