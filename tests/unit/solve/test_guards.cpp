// The numerical guards: a run whose numbers go wrong stops at once with a status that says how (divergent,
// nonfinite, breakdown) and a detail that says where, instead of running to its iteration limit; and a system at
// the edge of convergence is not mistaken for a divergent one.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "radiosity/solve/methods/divergence.hpp"
#include "radiosity/solve/solve.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

constexpr size_t kN = 33;  // 1/(n-1) = 1/32 is exact in float

SolveConfig config(const std::string& backend, const std::string& method, const std::string& precision) {
  SolveConfig c = solve_config(backend, "aos", method, precision);
  c.tol = 1e-6;
  c.max_iter = 100000;
  return c;
}

// Every patch sees every other alike with ρ = 1, and F's rows sum to `row_sum`: ρF's spectral radius is row_sum.
Problem uniform_room(double row_sum) {
  Problem p = closed_problem(kN, std::vector<Rgb>(kN, Rgb{1, 1, 1}), std::vector<Rgb>(kN, Rgb{1, 0.5, 0.25}));
  for (float& f : p.F) f *= float(row_sum);
  return p;
}

bool all_finite(const std::vector<Rgb>& B) {
  for (const Rgb& b : B)
    for (double x : b)
      if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

TEST(Guards, StatusName) { EXPECT_STREQ(to_string(SolveStatus::divergent), "divergent"); }

// ρF with rows summing to 1.5: Jacobi's iterates grow by 1.5 per step. Every Jacobi backend stops as soon as the
// residual is 1e4 times its first value (log 1e4 / log 1.5 ≈ 23 steps), with the iterate it had, still finite.
TEST(Guards, JacobiDivergenceStopsEarly) {
  const Problem p = uniform_room(1.5);
  for (const char* backend : {"serial", "openmp"})
    for (const char* layout : {"aos", "soa"})
      for (const char* precision : {"float", "double"})
        for (long steps : {0L, 1000L}) {
          SCOPED_TRACE(std::string(backend) + " " + layout + " " + precision + " steps " + std::to_string(steps));
          SolveConfig c = config(backend, "jacobi", precision);
          c.layout = parse_layout(layout);
          c.steps = steps;
          const SolveResult r = solve(p.sys, c);
          EXPECT_EQ(r.status, SolveStatus::divergent);
          EXPECT_GE(r.iterations, 20);
          EXPECT_LE(r.iterations, 30);
          EXPECT_NE(r.detail.find("jacobi: the residual in channel r grew to"), std::string::npos) << r.detail;
          EXPECT_TRUE(all_finite(r.B));
        }
  SolveConfig c = config("original", "jacobi", "float");
  c.steps = 1000;
  const SolveResult r = solve(p.sys, c);
  EXPECT_EQ(r.status, SolveStatus::divergent);
  EXPECT_LE(r.iterations, 30);
  EXPECT_EQ(r.matrix_passes, r.iterations);
  EXPECT_NE(r.detail.find("original: the residual"), std::string::npos) << r.detail;
}

// Rows summing to exactly 1 with ρ = 1: the residual neither shrinks nor grows (B grows by E every step), and
// (I - ρF) B = E has no solution. That is no divergence: with a tolerance the run stops as stagnant, with the
// reason "no solution", after the stagnation window (on every Jacobi backend, Gauss-Seidel and SOR alike); fixed
// steps run to the end.
TEST(Guards, SpectralRadiusOneIsStagnationNotDivergence) {
  const Problem p = uniform_room(1.0);
  for (const char* backend : {"serial", "openmp"})
    for (const char* method : {"jacobi", "gauss-seidel"})
      for (const char* precision : {"float", "double"}) {
        SCOPED_TRACE(std::string(backend) + " " + method + " " + precision);
        SolveConfig c = config(backend, method, precision);
        c.max_iter = 300;
        const SolveResult r = solve(p.sys, c);
        EXPECT_EQ(r.status, SolveStatus::stagnant);
        EXPECT_EQ(r.detail.rfind(std::string("no solution: ") + method + ": the relative residual did not decrease", 0), 0u)
            << r.detail;
        EXPECT_GE(r.iterations, kStagnationWindow - 1);
        EXPECT_LE(r.iterations, kStagnationWindow + 5);
        EXPECT_TRUE(failed(r.status));
      }
  SolveConfig c = config("serial", "jacobi", "double");
  c.steps = 300;
  EXPECT_EQ(solve(p.sys, c).status, SolveStatus::steps_done);
  c = config("original", "jacobi", "float");
  c.steps = 300;
  EXPECT_EQ(solve(p.sys, c).status, SolveStatus::steps_done);
}

// The guard itself: a residual flat (or slowly growing) for the window, far above the tolerance, is stagnant; a
// slow but steady decrease (rate 1 - 1e-4 per step), a flat residual near the tolerance (held up by rounding) and a
// transient growth with its decrease after are not.
TEST(Guards, StagnationNeedsAFlatResidualFarAboveTheTolerance) {
  auto steps_to_stagnate = [](double tol, bool dbl, auto value) {
    Stagnation s(tol, dbl);
    for (long k = 1; k <= 2000; ++k) {
      const double v = value(k);
      if (!s(k, Rgb{v, v / 2, v / 4}).empty()) return k;
    }
    return 0L;
  };
  EXPECT_EQ(steps_to_stagnate(1e-6, true, [](long) { return 1.008; }), kStagnationWindow);
  EXPECT_EQ(steps_to_stagnate(1e-6, false, [](long k) { return 1.0 + 1e-4 * double(k % 3); }), kStagnationWindow);
  EXPECT_EQ(steps_to_stagnate(1e-6, false, [](long k) { return std::pow(1 + 1e-4, double(k)); }), kStagnationWindow);
  EXPECT_EQ(steps_to_stagnate(1e-6, false, [](long k) { return std::pow(1 - 1e-4, double(k)); }), 0);
  EXPECT_EQ(steps_to_stagnate(1e-6, true, [](long k) { return std::pow(1 - 1e-7, double(k)); }), 0);
  EXPECT_EQ(steps_to_stagnate(1e-6, true, [](long) { return 5e-4; }), 0);   // below 1000 tol
  EXPECT_EQ(steps_to_stagnate(1e-9, false, [](long) { return 1e-4; }), 0);  // below 1e4 float epsilon
  // growth ten times in a step, then a decrease at 0.98 per step: never flat
  EXPECT_EQ(steps_to_stagnate(1e-6, true, [](long k) { return k < 2 ? 1.0 : 9.8 * std::pow(0.98, double(k - 2)); }), 0);
}

// One large patch seen whole by 100 small ones (F_i0 = 0.99) that it sees little of (F_0i = 0.0099): a residual
// on the large patch spreads to the small ones and its 2-norm grows ten times in the first step, then shrinks.
// Transient growth within √n of the start is what every convergent system may show; it must not stop the run.
TEST(Guards, TransientGrowthIsNotDivergence) {
  const size_t n = 101;
  Problem p;
  p.F.assign(n * n, 0.0f);
  for (size_t i = 1; i < n; ++i) {
    p.F[i * n] = 0.99f;
    p.F[i] = 0.0099f;
  }
  p.sys.n = n;
  p.sys.matrix = dense_float32_view(p.F.data(), p.sys.n);
  p.sys.reflectivity.assign(n, Rgb{0.99, 0.99, 0.99});
  p.sys.emission.assign(n, Rgb{0, 0, 0});
  p.sys.emission[0] = {1, 1, 1};
  p.sys.initial.assign(n, Rgb{0, 0, 0});
  SolveConfig c = config("serial", "jacobi", "double");
  c.tol = 1e-10;
  const SolveResult r = solve(p.sys, c);
  EXPECT_EQ(r.status, SolveStatus::converged) << r.detail;
  // The growth is real: b_0 = 0, b_1 = e, and ‖r(b_1)‖ / ‖r(b_0)‖ = 0.99 · 0.99 · √100 = 9.8.
  EXPECT_GT(relative_residual(p.sys, p.sys.emission)[0], 9.7 * relative_residual(p.sys, p.sys.initial)[0]);
}

// An emission that is finite in double but not in float (1e39 > FLT_MAX) becomes Inf when the float backends load
// it: the first step's residual is not finite, and the run says so. In double the same system solves.
TEST(Guards, EmissionBeyondFloatIsNonfiniteInFloatOnly) {
  Problem p = random_problem(40, 61);
  p.sys.emission[3] = {1e39, 1e39, 1e39};
  p.sys.initial[3] = p.sys.emission[3];
  for (const char* backend : {"serial", "openmp"})
    for (const char* method : {"jacobi", "bicgstab"}) {
      SCOPED_TRACE(std::string(backend) + " " + method);
      const SolveResult f = solve(p.sys, config(backend, method, "float"));
      EXPECT_EQ(f.status, SolveStatus::nonfinite) << f.detail;
      EXPECT_LE(f.iterations, 1);
      EXPECT_EQ(solve(p.sys, config(backend, method, "double")).status, SolveStatus::converged);
    }
  SolveConfig c = config("original", "jacobi", "float");
  c.steps = 32;
  const SolveResult r = solve(p.sys, c);
  EXPECT_EQ(r.status, SolveStatus::nonfinite);
  EXPECT_EQ(r.iterations, 1);
}

// A = I - F with F = [[0, 2], [0, 0]] (ρ = 1) and, in channel g, r0 = e = (-1, 1): α = 1/2, s = (1/2, 1/2) and
// t = A s = (-1/2, 1/2), all exact: t·s = 0, so ω = 0 and the next β would divide by it. Channels r and b, with
// e = (1, 0), converge in the same iteration; the detail names the channel that broke.
TEST(Guards, BicgstabOmegaBreakdown) {
  std::vector<float> F = {0, 2, 0, 0};
  System s;
  s.n = 2;
  s.matrix = dense_float32_view(F.data(), s.n);
  s.emission = {{1, -1, 1}, {0, 1, 0}};
  s.reflectivity = {{1, 1, 1}, {1, 1, 1}};
  s.initial = {{0, 0, 0}, {0, 0, 0}};
  for (const char* precision : {"float", "double"}) {
    const SolveResult r = solve(s, config("serial", "bicgstab", precision));
    EXPECT_EQ(r.status, SolveStatus::breakdown) << precision;
    EXPECT_NE(r.detail.find("omega = t.s/t.t ~ 0 in channel g at iteration 1"), std::string::npos) << r.detail;
    EXPECT_TRUE(all_finite(r.B));
  }
}

// A 3×3 system, found by an exact search, whose first BiCG-STAB iterate leaves r1 orthogonal to r̂ = r0
// (r0 = (1, -1, -1), r1 = (-3, -1, -2)/14): ρ = r̂·r1 = 0 (up to rounding) at iteration 2, in channel b only.
TEST(Guards, BicgstabRhoBreakdown) {
  std::vector<float> F = {0, 0.5f, 0.5f, 0.5f, 0, 1, 1, 0, 0};
  System s;
  s.n = 3;
  s.matrix = dense_float32_view(F.data(), s.n);
  s.emission = {{1, 1, 1}, {1, 0, -1}, {0, 0, -1}};
  s.reflectivity.assign(3, Rgb{1, 1, 1});
  s.initial.assign(3, Rgb{0, 0, 0});
  for (const char* precision : {"float", "double"}) {
    const SolveResult r = solve(s, config("serial", "bicgstab", precision));
    EXPECT_EQ(r.status, SolveStatus::breakdown) << precision;
    EXPECT_NE(r.detail.find("rho = r^.r ~ 0 in channel b at iteration 2"), std::string::npos) << r.detail;
    EXPECT_EQ(r.iterations, 1);
  }
}
