// The test problem against references independent of the solver: f = -Δu checked by finite differences of the
// closed-form u, and the 5-point stencil of the exact solution reproducing h² f up to O(h⁴).
#include <gtest/gtest.h>

#include <cmath>

#include "poisson/config/problem.hpp"

using poisson::exact_u;
using poisson::rhs_f;

TEST(Problem, RhsIsMinusLaplacianOfExactSolution) {
  const double d = 1e-4;
  for (double x : {0.1, 0.37, 0.5, 0.81})
    for (double y : {0.05, 0.42, 0.66, 0.93}) {
      const double lap = (exact_u(x + d, y) + exact_u(x - d, y) + exact_u(x, y + d) + exact_u(x, y - d) -
                          4 * exact_u(x, y)) / (d * d);
      EXPECT_NEAR(-lap, rhs_f(x, y), 1e-5 * (1 + std::abs(rhs_f(x, y)))) << "at " << x << "," << y;
    }
}

TEST(Problem, ExactSolutionVanishesOnTheBoundary) {
  for (double t : {0.0, 0.25, 0.5, 1.0}) {
    EXPECT_NEAR(exact_u(0, t), 0, 1e-30);
    EXPECT_NEAR(exact_u(1, t), 0, 1e-30);
    EXPECT_NEAR(exact_u(t, 0), 0, 1e-30);
    EXPECT_NEAR(exact_u(t, 1), 0, 1e-30);
  }
}

TEST(Problem, StencilOfExactSolutionMatchesScaledRhs) {
  // (A u)_ij - h² f_ij is the local truncation error times h²: O(h⁴). Halving h must cut it by about 16.
  double prev = 0;
  for (long n : {31, 63, 127}) {
    poisson::Grid g{n};
    double worst = 0;
    for (long j = 1; j < n - 1; ++j)
      for (long i = 1; i < n - 1; ++i) {
        const double au = 4 * g.u(i, j) - g.u(i - 1, j) - g.u(i + 1, j) - g.u(i, j - 1) - g.u(i, j + 1);
        worst = std::max(worst, std::abs(au - g.b(i, j)));
      }
    if (prev > 0) {
      EXPECT_NEAR(prev / worst, 16.0, 1.0) << "n = " << n;
    }
    prev = worst;
  }
}

// The tables give Grid's b and u bit for bit (the backends that use them must solve the same system as serial).
TEST(Problem, GridTableIsGridBitForBit) {
  for (long n : {1L, 7L, 64L, 1023L}) {
    const poisson::Grid g{n};
    const poisson::GridTable t(g);
    for (long j = 0; j < n; j += 1 + n / 37) {
      for (long i = 0; i < n; ++i) {
        EXPECT_EQ(t.b(i, j), g.b(i, j)) << n << " " << i << " " << j;
        EXPECT_EQ(t.u(i, j), g.u(i, j)) << n << " " << i << " " << j;
      }
    }
  }
}
