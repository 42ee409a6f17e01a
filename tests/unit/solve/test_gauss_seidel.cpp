// Gauss-Seidel and SOR (issue 21) against the direct solve of reference.hpp on every CPU backend, layout and
// precision; SOR with ω = 1 is Gauss-Seidel; one thread is the plain sweep in patch order (checked against a sweep
// written here); the backends that do not run them refuse them.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/solve/solve.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

SolveConfig config(const std::string& backend, const std::string& layout, const std::string& method,
                   const std::string& precision, int threads) {
  SolveConfig c = solve_config(backend, layout, method, precision, 0, threads);
  c.max_iter = 2000;
  return c;
}

// The textbook sweep in patch order, in double: b_i = e_i + ρ_i Σ_j F_ij b_j with the newest b_j.
std::vector<Rgb> sweeps_in_patch_order(const System& s, long sweeps, double omega) {
  std::vector<Rgb> b = s.initial;
  for (long k = 0; k < sweeps; ++k)
    for (size_t i = 0; i < s.n; ++i)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        for (size_t j = 0; j < s.n; ++j) sum += double(dense_float32(s)[i * s.n + j]) * b[j][c];
        b[i][c] = (1 - omega) * b[i][c] + omega * (s.emission[i][c] + s.reflectivity[i][c] * sum);
      }
  return b;
}

}  // namespace

TEST(GaussSeidel, AgreesWithTheDirectSolveOnEveryCpuBackend) {
  const Problem p = random_problem(97, 31, 0.2, 0.9);  // 97 rows: thread blocks of 16-row multiples, one ragged
  const std::vector<Rgb> exact = direct_solve(p.sys);
  for (const char* method : {"gauss-seidel", "sor"})
    for (const char* backend : {"serial", "openmp"})
      for (const char* layout : {"aos", "soa"})
        for (const char* precision : {"float", "double"})
          for (int threads : {1, 2, 3}) {
            if (std::string(backend) == "serial" && threads > 1) continue;
            SCOPED_TRACE(std::string(method) + " " + backend + " " + layout + " " + precision + " " +
                         std::to_string(threads));
            SolveConfig c = config(backend, layout, method, precision, threads);
            if (std::string(method) == "sor") c.omega = 1.15;
            const SolveResult r = solve(p.sys, c);
            ASSERT_EQ(r.status, SolveStatus::converged) << r.detail;
            // A relative residual tol bounds the relative error by about tol · cond(A) (< 20 here).
            EXPECT_LT(rel_diff(r.B, exact), precision == std::string("float") ? 3e-5 : 3e-11);
            EXPECT_LE(r.rel_residual[0], 2 * c.tol);
            EXPECT_EQ(r.matrix_passes, r.iterations + 1);  // the last sweep was the check of the answer
          }
}

TEST(GaussSeidel, OneThreadIsTheSweepInPatchOrder) {
  const Problem p = random_problem(50, 37);
  for (double omega : {1.0, 0.7, 1.4})
    for (const char* backend : {"serial", "openmp"}) {
      SCOPED_TRACE(std::string(backend) + " " + std::to_string(omega));
      SolveConfig c = config(backend, "aos", omega == 1.0 ? "gauss-seidel" : "sor", "double", 1);
      c.omega = omega;
      c.steps = 6;
      const SolveResult r = solve(p.sys, c);
      EXPECT_LT(rel_diff(r.B, sweeps_in_patch_order(p.sys, 6, omega)), 1e-13);
    }
}

TEST(GaussSeidel, SorWithOmegaOneIsGaussSeidelBitForBit) {
  const Problem p = random_problem(70, 41);
  for (const char* backend : {"serial", "openmp"})
    for (const char* layout : {"aos", "soa"})
      for (const char* precision : {"float", "double"}) {
        SCOPED_TRACE(std::string(backend) + " " + layout + " " + precision);
        const SolveResult gs = solve(p.sys, config(backend, layout, "gauss-seidel", precision, 2));
        SolveConfig c = config(backend, layout, "sor", precision, 2);
        c.omega = 1.0;
        const SolveResult sor = solve(p.sys, c);
        EXPECT_EQ(gs.iterations, sor.iterations);
        EXPECT_EQ(gs.B, sor.B);
      }
}

// Serial and openmp on one thread sweep the same one block with the same code: the same bits.
TEST(GaussSeidel, SerialIsOpenMPOnOneThread) {
  const Problem p = random_problem(64, 43);
  for (const char* layout : {"aos", "soa"}) {
    const SolveResult a = solve(p.sys, config("serial", layout, "gauss-seidel", "float", 1));
    const SolveResult b = solve(p.sys, config("openmp", layout, "gauss-seidel", "float", 1));
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.B, b.B) << layout;
  }
}

TEST(GaussSeidel, RefusedWhereNotRunAndOmegaChecked) {
  const Problem p = random_problem(20, 47);
  for (const char* backend : {"original", "cuda", "cublas", "hybrid", "mpi"}) {
    SolveConfig c = config(backend, "aos", "gauss-seidel", "float", 1);
    EXPECT_THROW(solve(p.sys, c), hpcgi::UsageError) << backend;
  }
  for (double omega : {0.0, 2.0, -1.0}) {
    SolveConfig c = config("serial", "aos", "sor", "float", 1);
    c.omega = omega;
    EXPECT_THROW(solve(p.sys, c), hpcgi::UsageError) << omega;
  }
  SolveConfig c = config("serial", "aos", "gauss-seidel", "float", 1);
  c.omega = 1.3;  // omega is for sor only: refused, not ignored
  EXPECT_THROW(solve(p.sys, c), hpcgi::UsageError);
}
