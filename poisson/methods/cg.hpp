// Conjugate gradients written once for every backend, in the two variants of kernels.hpp: classic
// (Hestenes-Stiefel with three fused kernels) and onesweep (Chronopoulos-Gear, one pass per iteration). Both give
// the same iterates in exact arithmetic.
#pragma once
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

#include "common/errors.hpp"
#include "common/timer.hpp"
#include "poisson/contract/kernels.hpp"

namespace poisson {

// How a solve ended: converged, stopped at max_iter, the fixed --steps done (main's, from max_iter), broken down.
enum class Status { converged, max_iter, steps_done, breakdown };
inline const char* to_string(Status s) {
  switch (s) {
    case Status::converged: return "converged";
    case Status::max_iter: return "max_iter";
    case Status::steps_done: return "steps_done";
    case Status::breakdown: return "breakdown";
  }
  return "unknown";
}

struct CgResult {
  long iterations = 0;
  double rel_residual = 0;       // recursive ‖r_k‖/‖r_0‖, the one the stopping test reads
  double true_rel_residual = 0;  // ‖b - A x_k‖/‖b‖ recomputed from x_k
  double error_inf = 0;          // ‖u - u_h‖∞ against the exact solution
  Status status = Status::max_iter;
  std::string breakdown;         // what broke (empty unless status is breakdown)
  double init_s = 0;             // x = 0, r = p = b
  double solve_s = 0;            // the iterations
  double check_s = 0;            // true residual and error after the solve
};

using CgProgress = std::function<void(long, double)>;

namespace detail {
// The start of run_cg, run_pcg and run_fmg: x = 0, r = p = b; the init time; converged at once where b = 0 (x = 0 is
// exact). Returns r₀·r₀; t restarts for the solve.
template <class T>
double start(Kernels<T>& k, CgResult& res, hpcgi::Timer& t) {
  const double rr0 = k.init();
  res.init_s = t.seconds();
  t.reset();
  res.status = rr0 == 0.0 ? Status::converged : Status::max_iter;
  return rr0;
}

// The checks inside the loops of run_cg and run_pcg: false, with the reason in res, when p·Ap is not finite and
// positive, or r·r is not finite.
inline bool pw_ok(CgResult& res, double pw, long it) {
  if (std::isfinite(pw) && pw > 0.0) return true;
  res.status = Status::breakdown;
  res.breakdown = "p·Ap = " + std::to_string(pw) + " at iteration " + std::to_string(it) +
                  " (must be finite and > 0 for a symmetric positive definite matrix)";
  return false;
}
inline bool rr_ok(CgResult& res, double rr, long it) {
  if (std::isfinite(rr)) return true;
  res.status = Status::breakdown;
  res.breakdown = "r·r is not finite at iteration " + std::to_string(it);
  return false;
}
// After iteration it with the new r·r: the relative residual, the progress call, and whether it has converged.
inline bool reached(CgResult& res, double rr, double rr0, long it, double tol, const CgProgress& progress) {
  res.iterations = it;
  res.rel_residual = std::sqrt(rr / rr0);
  if (progress) progress(it, res.rel_residual);
  if (res.rel_residual > tol) return false;
  res.status = Status::converged;
  return true;
}

// The checks after the solve, the same for both variants: true residual from x, error against u.
template <class T>
void finish(Kernels<T>& k, CgResult& res, double rr0, hpcgi::Timer& t) {
  res.solve_s = t.seconds();
  t.reset();
  res.true_rel_residual = rr0 > 0 ? std::sqrt(k.true_residual2() / rr0) : 0.0;
  res.error_inf = k.error_inf();
  res.check_s = t.seconds();
}
}  // namespace detail

// progress(iteration, relative residual) is called after every iteration (for a progress line on long runs).
template <class T>
CgResult run_cg(Kernels<T>& k, double tol, long max_iter,
                const CgProgress& progress = nullptr) {
  CgResult res;
  hpcgi::Timer t;
  const double rr0 = detail::start(k, res, t);
  double rr = rr0;
  for (long it = 1; it <= max_iter && res.status != Status::converged; ++it) {
    const double pw = k.calc_w();
    if (!detail::pw_ok(res, pw, it)) break;
    const double alpha = rr / pw;
    const double rr_new = k.calc_ur(alpha);
    res.iterations = it;
    if (!detail::rr_ok(res, rr_new, it) || detail::reached(res, rr_new, rr0, it, tol, progress)) break;
    k.calc_p(rr_new / rr);
    rr = rr_new;
  }
  detail::finish(k, res, rr0, t);
  return res;
}

// Chronopoulos and Gear (1989): with γ_k = r_k·r_k and δ_k = r_k·Ar_k from the previous sweep,
//   β_k = γ_k / γ_{k-1},  p_k·Ap_k = δ_k - β_k γ_k / α_{k-1},  α_k = γ_k / p_k·Ap_k,
// (p_k·Ap_k = δ_k - β_k² p_{k-1}·Ap_{k-1} since p_{k-1}·Ar_k = 0), so both scalars of step k are known before the
// sweep that applies them, and one reduction of (γ, δ) per iteration replaces the two of the classic variant.
template <class T>
CgResult run_cg_onesweep(OneSweepKernels<T>& k, double tol, long max_iter, const CgProgress& progress = nullptr) {
  CgResult res;
  hpcgi::Timer t;
  double rr = k.init();
  const double rr0 = rr;
  double rAr = rr0 > 0 ? k.r_Ar() : 0.0;
  res.init_s = t.seconds();
  t.reset();
  res.status = rr0 == 0.0 ? Status::converged : Status::max_iter;
  double rr_prev = 0, alpha_prev = 0;
  for (long it = 1; it <= max_iter && res.status != Status::converged; ++it) {
    const double beta = it == 1 ? 0.0 : rr / rr_prev;
    const double pw = it == 1 ? rAr : rAr - beta * rr / alpha_prev;
    if (!std::isfinite(pw) || pw <= 0.0) {
      res.status = Status::breakdown;
      res.breakdown = "p·Ap = " + std::to_string(pw) + " at iteration " + std::to_string(it) +
                      " (from the Chronopoulos-Gear recurrence; must be finite and > 0 for a symmetric positive "
                      "definite matrix)";
      break;
    }
    const double alpha = rr / pw;
    const SweepDots d = k.sweep(alpha, beta);
    res.iterations = it;
    if (!std::isfinite(d.rr) || !std::isfinite(d.rAr)) {
      res.status = Status::breakdown;
      res.breakdown = "r·r or r·Ar is not finite at iteration " + std::to_string(it);
      break;
    }
    res.rel_residual = std::sqrt(d.rr / rr0);
    if (progress) progress(it, res.rel_residual);
    if (res.rel_residual <= tol) res.status = Status::converged;
    rr_prev = rr;
    rr = d.rr;
    rAr = d.rAr;
    alpha_prev = alpha;
  }
  detail::finish(k, res, rr0, t);
  return res;
}

// CG preconditioned by M⁻¹ (one multigrid V-cycle, mg.hpp), the classic shape with z = M⁻¹ r between the
// updates; the stopping test reads the unpreconditioned ‖r‖/‖r₀‖ as plain CG (and PETSc's UNPRECONDITIONED norm).
template <class T>
CgResult run_pcg(Kernels<T>& k, Preconditioned& m, double tol, long max_iter, const CgProgress& progress = nullptr) {
  CgResult res;
  hpcgi::Timer t;
  const double rr0 = detail::start(k, res, t);
  // fused: p = z + βp is made with p·Ap (calc_p_pw) at the top of the iteration, not after the V-cycle.
  const bool fused = m.fused_updates();
  double rz = 0, beta = 0;
  if (rr0 > 0) {
    rz = m.precondition();
    if (!fused) m.calc_p_z(0.0);
  }
  for (long it = 1; it <= max_iter && res.status != Status::converged; ++it) {
    if (!std::isfinite(rz) || rz <= 0.0) {
      res.status = Status::breakdown;
      res.breakdown = "r·M⁻¹r = " + std::to_string(rz) + " at iteration " + std::to_string(it) +
                      " (must be finite and > 0 for a symmetric positive definite preconditioner)";
      break;
    }
    const double pw = fused ? m.calc_p_pw(beta) : k.calc_w();
    if (!detail::pw_ok(res, pw, it)) break;
    const double rr = fused ? m.calc_ur_p(rz / pw) : k.calc_ur(rz / pw);
    res.iterations = it;
    if (!detail::rr_ok(res, rr, it) || detail::reached(res, rr, rr0, it, tol, progress)) break;
    const double rz_new = m.precondition();
    if (fused)
      beta = rz_new / rz;
    else
      m.calc_p_z(rz_new / rz);
    rz = rz_new;
  }
  detail::finish(k, res, rr0, t);
  return res;
}

// --method fmg: the full-multigrid F-cycle (mg.hpp fmg) as the first iteration, then solver V-cycles, until the same
// stopping test as CG's, ‖r‖/‖r₀‖ <= tol, with r = b - A x of the new x (Preconditioned::solve_cycle). An
// iteration is one fine-grid V-cycle (the F-cycle runs one on the fine grid, and about 1/3 of one below it).
template <class T>
CgResult run_fmg(Kernels<T>& k, Preconditioned& m, double tol, long max_iter, const CgProgress& progress = nullptr) {
  CgResult res;
  hpcgi::Timer t;
  const double rr0 = detail::start(k, res, t);
  for (long it = 1; it <= max_iter && res.status != Status::converged; ++it) {
    const double rr = m.solve_cycle(it == 1);
    res.iterations = it;
    if (!detail::rr_ok(res, rr, it) || detail::reached(res, rr, rr0, it, tol, progress)) break;
  }
  detail::finish(k, res, rr0, t);
  return res;
}

// Runs the variant the backend was made for (cfg.variant; check_config refused a variant it does not have).
template <class T>
CgResult run_variant(Kernels<T>& k, Variant variant, double tol, long max_iter, const CgProgress& progress = nullptr) {
  if (variant == Variant::classic) return run_cg(k, tol, max_iter, progress);
  OneSweepKernels<T>* s = k.one_sweep();
  if (!s) throw std::logic_error("backend made without the one-sweep kernels check_config promised");
  return run_cg_onesweep(*s, tol, max_iter, progress);
}

// Runs what cfg asks for: with --method fmg full multigrid, with --precond mg the preconditioned CG, otherwise
// cfg.variant. The configuration was checked (check_config): a backend lacking what it asks is a bug here.
template <class T>
CgResult run_config(Kernels<T>& k, const Config& cfg, double tol, long max_iter,
                    const CgProgress& progress = nullptr) {
  if (!cfg.multigrid()) return run_variant(k, cfg.variant, tol, max_iter, progress);
  Preconditioned* m = k.multigrid();
  if (!m) throw std::logic_error("backend made without the multigrid kernels check_config promised");
  return cfg.method == Method::fmg ? run_fmg(k, *m, tol, max_iter, progress) : run_pcg(k, *m, tol, max_iter, progress);
}

}  // namespace poisson
