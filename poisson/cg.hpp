// Conjugate gradients written once for every backend (Hestenes-Stiefel with the fused kernels of kernels.hpp).
#pragma once
#include <cmath>
#include <functional>
#include <string>

#include "common/timer.hpp"
#include "poisson/kernels.hpp"

namespace poisson {

struct CgResult {
  long iterations = 0;
  double rel_residual = 0;       // recursive ‖r_k‖/‖r_0‖, the one the stopping test reads
  double true_rel_residual = 0;  // ‖b - A x_k‖/‖b‖ recomputed from x_k
  double error_inf = 0;          // ‖u - u_h‖∞ against the exact solution
  std::string status;            // converged | max_iter | breakdown
  std::string breakdown;         // what broke (empty unless status == breakdown)
  double init_s = 0;             // x = 0, r = p = b
  double solve_s = 0;            // the iterations
  double check_s = 0;            // true residual and error after the solve
};

// progress(iteration, relative residual) is called after every iteration (for a progress line on long runs).
template <class T>
CgResult run_cg(Kernels<T>& k, double tol, long max_iter,
                const std::function<void(long, double)>& progress = nullptr) {
  CgResult res;
  hpcgi::Timer t;
  double rr = k.init();
  const double rr0 = rr;
  res.init_s = t.seconds();
  t.reset();
  res.status = "max_iter";
  if (rr0 == 0.0) res.status = "converged";  // b = 0: x = 0 is exact
  for (long it = 1; it <= max_iter && res.status != "converged"; ++it) {
    const double pw = k.calc_w();
    if (!std::isfinite(pw) || pw <= 0.0) {
      res.status = "breakdown";
      res.breakdown = "p·Ap = " + std::to_string(pw) + " at iteration " + std::to_string(it) +
                      " (must be finite and > 0 for a symmetric positive definite matrix)";
      break;
    }
    const double alpha = rr / pw;
    const double rr_new = k.calc_ur(alpha);
    res.iterations = it;
    if (!std::isfinite(rr_new)) {
      res.status = "breakdown";
      res.breakdown = "r·r is not finite at iteration " + std::to_string(it);
      break;
    }
    res.rel_residual = std::sqrt(rr_new / rr0);
    if (progress) progress(it, res.rel_residual);
    if (res.rel_residual <= tol) {
      res.status = "converged";
      break;
    }
    k.calc_p(rr_new / rr);
    rr = rr_new;
  }
  res.solve_s = t.seconds();
  t.reset();
  res.true_rel_residual = rr0 > 0 ? std::sqrt(k.true_residual2() / rr0) : 0.0;
  res.error_inf = k.error_inf();
  res.check_s = t.seconds();
  return res;
}

}  // namespace poisson
