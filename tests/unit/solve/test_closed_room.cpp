// A closed room: n patches of equal area that all see each other alike (F_ij = 1/(n-1), rows and columns sum
// to 1). Physics gives two checks that need no solver of ours:
//  - uniform ρ and E: every patch receives what the average patch sends, so B = E + ρB, B = E/(1-ρ);
//  - any ρ and E (ρ > 0): light is only absorbed, never lost, so what the patches absorb, Σ A_i (B_i - E_i)
//    (1-ρ_i)/ρ_i (reflected radiosity over ρ is what arrived; the part 1-ρ of it stays), equals what they emit,
//    Σ A_i E_i. (Sum over i of A_i · arrival_i = Σ_j A_j B_j by reciprocity and unit row sums.)
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "radiosity/solve/solve.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

constexpr size_t kN = 33;  // 1/(n-1) = 1/32 is exact in float: the rows sum to exactly 1

struct Case {
  std::string backend, layout, method, precision;
};

std::vector<Case> every_case() {
  std::vector<Case> cases = {{"original", "aos", "jacobi", "float"}};
  for (const char* backend : {"serial", "openmp"})
    for (const char* layout : {"aos", "soa"})
      for (const char* method : {"jacobi", "bicgstab"})
        for (const char* precision : {"float", "double"}) cases.push_back({backend, layout, method, precision});
  return cases;
}

SolveResult run(const System& s, const Case& k) {
  SolveConfig c;
  c.backend = k.backend;
  c.layout = parse_layout(k.layout);
  c.method = parse_method(k.method);
  c.precision = parse_precision(k.precision);
  c.tol = k.precision == "float" ? 1e-6 : 1e-13;
  c.max_iter = 2000;
  c.threads = 2;
  if (k.backend == "original") c.steps = 200;  // 0.85^200 ≈ 1e-14: as far as float goes
  return solve(s, c);
}

// Σ_i (B_i - E_i)(1-ρ_i)/ρ_i and Σ_i E_i per channel (equal areas cancel).
std::pair<Rgb, Rgb> absorbed_and_emitted(const System& s, const std::vector<Rgb>& B) {
  Rgb absorbed{0, 0, 0}, emitted{0, 0, 0};
  for (size_t i = 0; i < s.n; ++i)
    for (int c = 0; c < 3; ++c) {
      const double rho = s.reflectivity[i][c];
      absorbed[c] += (B[i][c] - s.emission[i][c]) * (1 - rho) / rho;
      emitted[c] += s.emission[i][c];
    }
  return {absorbed, emitted};
}

}  // namespace

TEST(ClosedRoom, UniformRoomReachesEOverOneMinusRho) {
  const Rgb rho{0.5, 0.7, 0.85}, E{1.0, 2.0, 0.5};
  const Problem p = closed_problem(kN, std::vector<Rgb>(kN, rho), std::vector<Rgb>(kN, E));
  for (const Case& k : every_case()) {
    SCOPED_TRACE(k.backend + " " + k.layout + " " + k.method + " " + k.precision);
    const SolveResult r = run(p.sys, k);
    EXPECT_NE(r.status, SolveStatus::breakdown) << r.detail;
    EXPECT_NE(r.status, SolveStatus::nonfinite) << r.detail;
    EXPECT_NE(r.status, SolveStatus::max_iter);
    // A relative residual tol bounds the relative error by tol·(1+ρ)/(1-ρ) ≤ 12.4·tol here.
    const double allowed = k.precision == "float" ? 2e-5 : 2e-12;
    for (size_t i = 0; i < kN; ++i)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.B[i][c], E[c] / (1 - rho[c]), allowed * E[c] / (1 - rho[c]));
    const auto [absorbed, emitted] = absorbed_and_emitted(p.sys, r.B);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(absorbed[c], emitted[c], allowed * emitted[c] / (1 - rho[c]));
  }
}

TEST(ClosedRoom, EveryRoomAbsorbsWhatItEmits) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Rgb> rho(kN), E(kN);
  for (size_t i = 0; i < kN; ++i)
    for (int c = 0; c < 3; ++c) {
      rho[i][c] = 0.1 + 0.8 * u(rng);
      E[i][c] = i % 4 == 0 ? 2 * u(rng) : 0.0;
    }
  const Problem p = closed_problem(kN, rho, E);
  for (const Case& k : every_case()) {
    if (k.precision == "float") continue;  // (1-ρ)/ρ up to 9 times float's rounding of B - E: see the uniform test
    SCOPED_TRACE(k.backend + " " + k.layout + " " + k.method);
    const SolveResult r = run(p.sys, k);
    ASSERT_EQ(r.status, SolveStatus::converged) << r.detail;
    const auto [absorbed, emitted] = absorbed_and_emitted(p.sys, r.B);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(absorbed[c], emitted[c], 1e-10 * emitted[c]);
  }
}
