// The test problem of Khuvis & Gobbert (HPCF-2014-6), reference [4] of the report:
//   -Δu = f on (0,1)², u = 0 on the boundary, u(x,y) = sin²(πx) sin²(πy),
//   f(x,y) = -2π² [cos(2πx) sin²(πy) + sin²(πx) cos(2πy)].
// N×N interior points, h = 1/(N+1), x_i = (i+1) h for i = 0..N-1 (the same in y).
// The 5-point system is scaled by h²: A u = b with A = [4 on the diagonal, -1 for each neighbour], b = h² f.
#pragma once
#include <cmath>

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

}  // namespace poisson
