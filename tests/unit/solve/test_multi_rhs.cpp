// The k-right-hand-side method (methods/multi_rhs.hpp) through the driver (multi_solve.hpp) against a float64 direct
// solve of each right-hand side: serial and openmp, k = 1 (F as stored), 3 and 9 (row blocks; two groups of right-
// hand sides), some rows of reflectivity 0; and its refusals and statuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/solve/multi_solve.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

// k right-hand sides on p's F and ρ: each emits on its own patches (q, q + k, ...), with its own colours.
std::vector<std::vector<Rgb>> right_hand_sides(size_t n, size_t k) {
  std::vector<std::vector<Rgb>> E(k, std::vector<Rgb>(n, Rgb{0, 0, 0}));
  for (size_t q = 0; q < k; ++q)
    for (size_t i = q; i < n; i += k + 2) E[q][i] = {1.0 + 0.1 * double(q), 0.5, 2.0 - 0.1 * double(q)};
  return E;
}

SolveConfig multi_config(const std::string& backend, double tol) {
  SolveConfig c;
  c.backend = backend;
  c.method = Method::jacobi;
  c.precision = Precision::double_;
  c.tol = tol;
  c.max_iter = 5000;
  c.threads = 2;
  return c;
}

}  // namespace

TEST(MultiRhs, EveryRightHandSideConvergesToItsDirectSolution) {
  const double tol = 1e-9;
  Problem p = random_problem(70, 11);
  for (size_t i = 3; i < p.sys.n; i += 7) p.sys.reflectivity[i] = {0, 0, 0};  // rows the products skip
  const double bound = norm2_bound(p.sys);
  ASSERT_LT(bound, 0.9);
  for (size_t k : {size_t(1), size_t(3), size_t(9)}) {
    const std::vector<std::vector<Rgb>> E = right_hand_sides(p.sys.n, k);
    for (const char* backend : {"serial", "openmp"}) {
      SCOPED_TRACE(std::string(backend) + " k = " + std::to_string(k));
      const MultiSolveResult r = solve_multi(p.sys, E, multi_config(backend, tol));
      ASSERT_EQ(r.status, SolveStatus::converged) << r.detail;
      ASSERT_EQ(r.B.size(), k);
      EXPECT_LE(r.max_residual, tol);
      EXPECT_GT(r.iterations, 5);
      EXPECT_EQ(r.matrix_passes, r.iterations + 1);
      for (size_t q = 0; q < k; ++q) {
        System one = p.sys;  // the same F (not owned) and ρ, right-hand side q
        one.emission = E[q];
        const std::vector<Rgb> exact = direct_solve(one);
        EXPECT_LE(rel_diff(r.B[q], exact), tol * (1 + bound) / (1 - bound)) << "right-hand side " << q;
        const Rgb res = relative_residual(one, r.B[q]);  // the independent float64 check
        EXPECT_LE(std::max({res[0], res[1], res[2]}), tol * 1.01);
      }
    }
  }
}

TEST(MultiRhs, SerialAndOpenmpGiveTheSameAnswer) {
  Problem p = random_problem(60, 5);
  const std::vector<std::vector<Rgb>> E = right_hand_sides(p.sys.n, 4);
  const MultiSolveResult s = solve_multi(p.sys, E, multi_config("serial", 1e-10));
  const MultiSolveResult o = solve_multi(p.sys, E, multi_config("openmp", 1e-10));
  ASSERT_EQ(s.iterations, o.iterations);
  for (size_t q = 0; q < E.size(); ++q) EXPECT_LE(rel_diff(s.B[q], o.B[q]), 1e-13);
}

TEST(MultiRhs, BackendsWithoutAKProductAreRefusedBeforeAnyWork) {
  Problem p = random_problem(20, 1);
  const std::vector<std::vector<Rgb>> E = right_hand_sides(p.sys.n, 2);
  for (const char* backend : {"original", "cuda", "cublas", "hybrid"}) {
    SCOPED_TRACE(backend);
    EXPECT_FALSE(has_multi_rhs(backend));
    EXPECT_THROW(solve_multi(p.sys, E, multi_config(backend, 1e-6)), hpcgi::UsageError);
  }
  EXPECT_TRUE(has_multi_rhs("serial") && has_multi_rhs("openmp"));
  SolveConfig bicg = multi_config("openmp", 1e-6);
  bicg.method = Method::bicgstab;
  EXPECT_THROW(solve_multi(p.sys, E, bicg), hpcgi::UsageError);
  EXPECT_THROW(solve_multi(p.sys, {}, multi_config("openmp", 1e-6)), hpcgi::UsageError);
}

TEST(MultiRhs, StopsAtMaxIterAndAtANonFiniteResidual) {
  Problem p = random_problem(30, 2);
  std::vector<std::vector<Rgb>> E = right_hand_sides(p.sys.n, 2);
  SolveConfig few = multi_config("openmp", 1e-12);
  few.max_iter = 3;
  const MultiSolveResult r = solve_multi(p.sys, E, few);
  EXPECT_EQ(r.status, SolveStatus::max_iter);
  EXPECT_EQ(r.iterations, 3);
  EXPECT_GT(r.max_residual, 1e-12);
  E[1][4][2] = std::numeric_limits<double>::quiet_NaN();
  const MultiSolveResult bad = solve_multi(p.sys, E, multi_config("openmp", 1e-6));
  EXPECT_EQ(bad.status, SolveStatus::nonfinite);
  EXPECT_NE(bad.detail.find("non-finite"), std::string::npos);
}
