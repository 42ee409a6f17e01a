// CG on every CPU backend against a reference none of them shares: a dense Gaussian elimination of the same
// 5-point system, and the backends against each other (same iterations, same solution).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/errors.hpp"
#include "poisson/cg.hpp"
#include "poisson/kernels.hpp"

namespace {

// Solves the h²-scaled 5-point system for N×N unknowns by Gaussian elimination with partial pivoting.
std::vector<double> dense_solve(long n) {
  const long m = n * n;
  poisson::Grid g{n};
  std::vector<double> a(m * m, 0.0), b(m);
  for (long j = 0; j < n; ++j)
    for (long i = 0; i < n; ++i) {
      const long k = j * n + i;
      a[k * m + k] = 4;
      if (i > 0) a[k * m + k - 1] = -1;
      if (i < n - 1) a[k * m + k + 1] = -1;
      if (j > 0) a[k * m + k - n] = -1;
      if (j < n - 1) a[k * m + k + n] = -1;
      b[k] = g.b(i, j);
    }
  for (long c = 0; c < m; ++c) {
    long piv = c;
    for (long r = c + 1; r < m; ++r)
      if (std::abs(a[r * m + c]) > std::abs(a[piv * m + c])) piv = r;
    for (long k = 0; k < m; ++k) std::swap(a[c * m + k], a[piv * m + k]);
    std::swap(b[c], b[piv]);
    for (long r = c + 1; r < m; ++r) {
      const double f = a[r * m + c] / a[c * m + c];
      for (long k = c; k < m; ++k) a[r * m + k] -= f * a[c * m + k];
      b[r] -= f * b[c];
    }
  }
  std::vector<double> x(m);
  for (long r = m - 1; r >= 0; --r) {
    double s = b[r];
    for (long k = r + 1; k < m; ++k) s -= a[r * m + k] * x[k];
    x[r] = s / a[r * m + r];
  }
  return x;
}

double max_rel_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    num = std::max(num, std::abs(a[k] - b[k]));
    den = std::max(den, std::abs(b[k]));
  }
  return num / den;
}

struct CgRun {
  poisson::CgResult res;
  std::vector<double> x;
};

template <class T>
CgRun run(const std::string& backend, long n, double tol) {
  poisson::Config cfg;
  cfg.n = n;
  cfg.backend = backend;
  auto k = poisson::make_kernels<T>(cfg);
  CgRun r{poisson::run_cg(*k, tol, 100000), {}};
  r.x = k->solution();
  return r;
}

}  // namespace

TEST(Cg, MatchesDenseDirectSolve) {
  for (long n : {1L, 2L, 3L, 7L, 12L}) {
    const auto ref = dense_solve(n);
    for (const char* b : {"serial", "openmp"}) {
      CgRun r = run<double>(b, n, 1e-13);
      EXPECT_EQ(r.res.status, "converged") << b << " n=" << n;
      EXPECT_LT(max_rel_diff(r.x, ref), 1e-11) << b << " n=" << n;
      // In exact arithmetic CG ends in at most as many steps as the matrix has distinct eigenvalues (≤ N²).
      EXPECT_LE(r.res.iterations, n * n) << b << " n=" << n;
    }
  }
}

TEST(Cg, OpenMpMatchesSerialAtN100) {
  CgRun s = run<double>("serial", 100, 1e-6);
  CgRun o = run<double>("openmp", 100, 1e-6);
  EXPECT_EQ(s.res.status, "converged");
  EXPECT_LE(std::abs(s.res.iterations - o.res.iterations), 1);
  EXPECT_LT(max_rel_diff(o.x, s.x), 1e-10);
  EXPECT_NEAR(o.res.error_inf, s.res.error_inf, 1e-10 * s.res.error_inf);
}

TEST(Cg, TrueResidualTracksRecursiveInDouble) {
  CgRun s = run<double>("openmp", 200, 1e-8);
  EXPECT_EQ(s.res.status, "converged");
  EXPECT_LE(s.res.rel_residual, 1e-8);
  EXPECT_NEAR(s.res.true_rel_residual, s.res.rel_residual, 0.05 * s.res.rel_residual);
}

TEST(Cg, FloatRunsAndItsTrueResidualIsReportedNotHidden) {
  // In float the recursive residual reaches 1e-6 but x cannot be stored accurately enough for the true residual
  // of the h²-scaled system to follow it: the run must say so through true_rel_residual.
  CgRun f = run<float>("openmp", 256, 1e-6);
  CgRun d = run<double>("openmp", 256, 1e-6);
  EXPECT_EQ(f.res.status, "converged");
  EXPECT_GT(f.res.true_rel_residual, 1e-4);
  EXPECT_LT(d.res.true_rel_residual, 2e-6);
  // The discretisation error still dominates at this N: float's solution is as good as double's within 1%.
  EXPECT_NEAR(f.res.error_inf, d.res.error_inf, 0.01 * d.res.error_inf);
}

TEST(Cg, UnknownOrUnbuiltBackendIsAUsageError) {
  poisson::Config cfg;
  cfg.backend = "nonsense";
  EXPECT_THROW(poisson::make_kernels<double>(cfg), hpcgi::UsageError);
}
