// bin/poisson's float64 check of its answer (as bin/radiosity's, exit status 5 when it fails): the error
// ||u - x||_inf against the exact solution u, computed in float64 by every backend (kernels.hpp error_inf, on the
// host for the GPU backends), must lie within a stated bound that holds for any correct answer:
//   ||u - x||_inf <= ||u - u_h||_inf + ||u_h - x||_2
//                 <= pi^4 h^2 / 6                      the 5-point stencil's discretisation error: truncation
//                                                      h^2/12 (max|u_xxxx| + max|u_yyyy|) = (4/3) pi^4 h^2, times
//                                                      1/8 by the discrete maximum principle on the unit square
//                  + rho ||b||_2 / lambda_min           the algebraic error: ||A^-1 r||_2 with ||r||_2 = rho ||b||_2
//                                                      (x_0 = 0, so r_0 = b) and lambda_min = 8 sin^2(pi h / 2)
//                                                      the smallest eigenvalue of the h^2-scaled matrix
//                  + eps                                x held in float or double: its rounding (|u_h| <= ~1), eps
//                                                      the precision's machine epsilon
// where rho is the relative residual the run claims: --tol when it converged, its recursive ||r||/||r0|| after
// --steps. A run that is no answer (broken down, stopped at --max-iter) is not checked (agreed null).
#pragma once
#include <string>

namespace poisson {

struct Check {
  double error_inf = 0;        // the run's ||u - x||_inf (float64)
  double discretisation = 0;   // pi^4 h^2 / 6
  double algebraic = 0;        // rho ||b||_2 / lambda_min
  double rounding = 0;         // the precision's epsilon
  double bound = 0;            // their sum, times the test hook's factor (below) if set
  double test_factor = 1;      // HPCGI_TEST_POISSON_BOUND: a test-only factor in (0, 1] that tightens the bound
  bool agreed = true;
};

// ||b||_2 of the h^2-scaled right-hand side for N interior points per dimension, in float64 (problem.hpp's b,
// summed in O(N) through its separable form).
double rhs_norm2(long n);

// The check of an answer of relative residual rho with error error_inf on N x N points, x held in a precision of
// machine epsilon eps. Reads the environment
// variable HPCGI_TEST_POISSON_BOUND (tests only: a factor in (0, 1] the bound is multiplied by, to plant a failure;
// anything else is refused with hpcgi::UsageError).
Check check_answer(long n, double rho, double eps, double error_inf);

}  // namespace poisson
