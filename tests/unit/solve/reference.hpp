// Test problems and the independent reference the solvers are checked against: a dense direct solve of
// A_c b_c = e_c (Gaussian elimination with partial pivoting, in double), written here and nowhere else.
#pragma once
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "radiosity/solve/core/system.hpp"

namespace solve_test {

using radiosity::Rgb;
using radiosity::System;

// A system that owns its F (System only points at it). Not copyable: a copy's System would point at the old F.
struct Problem {
  std::vector<float> F;
  System sys;
  Problem() = default;
  Problem(const Problem&) = delete;
  Problem& operator=(const Problem&) = delete;
  Problem(Problem&& o) noexcept : F(std::move(o.F)), sys(std::move(o.sys)) { sys.matrix = radiosity::dense_float32_view(F.data(), sys.n); }
};

// Random F >= 0 with F_ii = 0, scaled so that the largest row sum and the largest column sum are both
// `max_sum` (< 1: then ‖ρF‖₁ and ‖ρF‖∞, hence ‖ρF‖₂, are below max ρ · max_sum). ρ uniform in
// [rho_lo, rho_hi) per patch and channel; about a fifth of the patches emit (E in [0.5, 2)), the others not;
// B0 = RRV's max(attribute, E) with a random attribute in [0, 0.5).
inline Problem random_problem(size_t n, unsigned seed, double rho_lo = 0.0, double rho_hi = 0.9,
                              double max_sum = 0.99) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Problem p;
  std::vector<double> F(n * n, 0.0), row(n, 0.0), col(n, 0.0);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j)
      if (i != j) {
        F[i * n + j] = u(rng);
        row[i] += F[i * n + j];
        col[j] += F[i * n + j];
      }
  const double biggest = std::max(*std::max_element(row.begin(), row.end()), *std::max_element(col.begin(), col.end()));
  p.F.resize(n * n);
  // Rounding to float may push a sum up by a few ulps; scaling a hair below max_sum keeps it under.
  for (size_t k = 0; k < n * n; ++k) p.F[k] = float(F[k] * max_sum * (1 - 1e-6) / biggest);
  std::vector<Rgb> attribute(n);
  p.sys.n = n;
  p.sys.matrix = radiosity::dense_float32_view(p.F.data(), p.sys.n);
  p.sys.emission.resize(n);
  p.sys.reflectivity.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const bool emits = i % 5 == 0;
    for (int c = 0; c < 3; ++c) {
      p.sys.emission[i][c] = emits ? 0.5 + 1.5 * u(rng) : 0.0;
      p.sys.reflectivity[i][c] = rho_lo + (rho_hi - rho_lo) * u(rng);
      attribute[i][c] = 0.5 * u(rng);
    }
  }
  p.sys.initial = radiosity::rrv_initial_radiosity(attribute, p.sys.emission);
  return p;
}

// A closed room of n patches of equal area that all see each other alike: F_ij = 1/(n-1) off the diagonal, so
// every row and column sums to 1 (and A_i F_ij = A_j F_ji). With n - 1 a power of two, 1/(n-1) is exact in float.
inline Problem closed_problem(size_t n, const std::vector<Rgb>& rho, const std::vector<Rgb>& E) {
  Problem p;
  p.F.assign(n * n, float(1.0 / double(n - 1)));
  for (size_t i = 0; i < n; ++i) p.F[i * n + i] = 0;
  p.sys.n = n;
  p.sys.matrix = radiosity::dense_float32_view(p.F.data(), p.sys.n);
  p.sys.reflectivity = rho;
  p.sys.emission = E;
  p.sys.initial = E;
  return p;
}

// b_c solving (I - diag(ρ_c) F) b_c = e_c, by Gaussian elimination with partial pivoting in double.
inline std::vector<Rgb> direct_solve(const System& s) {
  const size_t n = s.n;
  std::vector<Rgb> B(n);
  for (int c = 0; c < 3; ++c) {
    std::vector<double> A(n * n), b(n);
    for (size_t i = 0; i < n; ++i) {
      for (size_t j = 0; j < n; ++j)
        A[i * n + j] = (i == j ? 1.0 : 0.0) - s.reflectivity[i][c] * double(radiosity::dense_float32(s)[i * n + j]);
      b[i] = s.emission[i][c];
    }
    for (size_t k = 0; k < n; ++k) {
      size_t piv = k;
      for (size_t i = k + 1; i < n; ++i)
        if (std::abs(A[i * n + k]) > std::abs(A[piv * n + k])) piv = i;
      if (A[piv * n + k] == 0) throw std::runtime_error("direct_solve: singular matrix");
      if (piv != k) {
        for (size_t j = 0; j < n; ++j) std::swap(A[k * n + j], A[piv * n + j]);
        std::swap(b[k], b[piv]);
      }
      for (size_t i = k + 1; i < n; ++i) {
        const double m = A[i * n + k] / A[k * n + k];
        for (size_t j = k; j < n; ++j) A[i * n + j] -= m * A[k * n + j];
        b[i] -= m * b[k];
      }
    }
    for (size_t k = n; k-- > 0;) {  // back substitution: b[k] becomes the solution's entry k
      for (size_t j = k + 1; j < n; ++j) b[k] -= A[k * n + j] * b[j];
      b[k] /= A[k * n + k];
      B[k][c] = b[k];
    }
  }
  return B;
}

// ‖x_c - y_c‖₂ / ‖y_c‖₂, the largest over the channels.
inline double rel_diff(const std::vector<Rgb>& x, const std::vector<Rgb>& y) {
  double worst = 0;
  for (int c = 0; c < 3; ++c) {
    double d = 0, r = 0;
    for (size_t i = 0; i < y.size(); ++i) {
      d += (x[i][c] - y[i][c]) * (x[i][c] - y[i][c]);
      r += y[i][c] * y[i][c];
    }
    worst = std::max(worst, std::sqrt(d / r));
  }
  return worst;
}

// An upper bound on ‖ρ_c F‖₂ over the channels: sqrt(‖·‖₁ ‖·‖∞), which is < 1 for the problems above.
inline double norm2_bound(const System& s) {
  double worst = 0;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> col(s.n, 0.0);
    double rowmax = 0;
    for (size_t i = 0; i < s.n; ++i) {
      double row = 0;
      for (size_t j = 0; j < s.n; ++j) {
        const double m = s.reflectivity[i][c] * radiosity::dense_float32(s)[i * s.n + j];
        row += m;
        col[j] += m;
      }
      rowmax = std::max(rowmax, row);
    }
    worst = std::max(worst, std::sqrt(rowmax * *std::max_element(col.begin(), col.end())));
  }
  return worst;
}

}  // namespace solve_test
