// The test problem of Khuvis & Gobbert (HPCF-2014-6), reference [4] of the report:
//   -Δu = f on (0,1)², u = 0 on the boundary, u(x,y) = sin²(πx) sin²(πy),
//   f(x,y) = -2π² [cos(2πx) sin²(πy) + sin²(πx) cos(2πy)].
// N×N interior points, h = 1/(N+1), x_i = (i+1) h for i = 0..N-1 (the same in y).
// The 5-point system is scaled by h²: A u = b with A = [4 on the diagonal, -1 for each neighbour], b = h² f.
#pragma once
#include <cmath>
#include <vector>

namespace poisson {

inline constexpr double kPi = 3.14159265358979323846;

inline double exact_u(double x, double y) {
  const double sx = std::sin(kPi * x), sy = std::sin(kPi * y);
  return sx * sx * sy * sy;
}

inline double rhs_f(double x, double y) {
  const double sx = std::sin(kPi * x), sy = std::sin(kPi * y);
  return -2.0 * kPi * kPi * (std::cos(2 * kPi * x) * sy * sy + sx * sx * std::cos(2 * kPi * y));
}

struct Grid {
  long n;  // interior points per dimension
  double h() const { return 1.0 / static_cast<double>(n + 1); }
  double coord(long i) const { return static_cast<double>(i + 1) * h(); }
  // b_ij = h² f(x_i, y_j): the right-hand side of the h²-scaled system.
  double b(long i, long j) const { return h() * h() * rhs_f(coord(i), coord(j)); }
  double u(long i, long j) const { return exact_u(coord(i), coord(j)); }
};

// b and u of Grid from tables of sin(π x_i) and cos(2π x_i) (the grid is square: the same in y), with the
// arithmetic of rhs_f and exact_u in the same order, so the values are Grid's bit for bit (a unit test checks),
// without four trigonometric calls per point (the openmp setup of N = 8192 took 18 s on 2 busy cores).
struct GridTable {
  explicit GridTable(const Grid& g) : hh(g.h() * g.h()), s(g.n), c2(g.n) {
    for (long i = 0; i < g.n; ++i) {
      s[i] = std::sin(kPi * g.coord(i));
      c2[i] = std::cos(2 * kPi * g.coord(i));
    }
  }
  double b(long i, long j) const { return hh * (-2.0 * kPi * kPi * (c2[i] * s[j] * s[j] + s[i] * s[i] * c2[j])); }
  double u(long i, long j) const { return s[i] * s[i] * s[j] * s[j]; }
  double hh;
  std::vector<double> s, c2;
};

}  // namespace poisson
