#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "radiosity/solve/methods.hpp"

namespace radiosity {
namespace {

const char* const kChannel[3] = {"r", "g", "b"};

Rgb negated(const Rgb& a) { return {-a[0], -a[1], -a[2]}; }

}  // namespace

// Three scalar recurrences, one per channel, share every kernel call. A channel whose residual meets tol is
// frozen by giving it α = ω = β = 0 (then x and r stay as they are), so it neither moves nor breaks down while
// the others go on. When every channel meets tol by the recurrence's residual, the true residual e - A x is
// computed; a channel that rounding left short (float) restarts from it, with r̂ = r.
template <class T>
MethodRun bicgstab(Kernels<T>& k, const Rgb& scale, const SolveConfig& cfg, const IterationCallback& callback) {
  enum Slot { X = 0, RHAT, P, V, T_, R_A, R_B };
  const Rgb one{1, 1, 1};
  // Breakdown: ρ = r̂·r or ω = t·s/t·t whose cosine (r̂·r / ‖r̂‖‖r‖, t·s / ‖t‖‖s‖) is below the working
  // precision, or r̂·v exactly 0; the next α or β would be noise or infinite.
  const double eps = std::numeric_limits<T>::epsilon();

  MethodRun run;
  run.answer = X;
  Snapshots<T> snapshots(k, callback);
  int r = R_A, s = R_B;  // r and s trade slots every iteration (r = s - ω t is computed in s's slot)
  Rgb rr, rhat2, rho_old, alpha, omega;
  bool active[3];
  bool fresh = true;  // first iteration after a (re)start: p = r

  enum class Start { work, converged, nonfinite };
  auto start = [&]() {
    k.matvec(r, X, -1, 1, 1);  // r = e - A x
    ++run.matrix_passes;
    k.copy(RHAT, r);
    rr = k.dot(r, r);
    rhat2 = rr;
    rho_old = alpha = omega = one;
    fresh = true;
    bool any = false;
    for (int c = 0; c < 3; ++c) {
      const double res = std::sqrt(rr[c]) / scale[c];
      if (!std::isfinite(res)) return Start::nonfinite;
      active[c] = res > cfg.tol;
      any = any || active[c];
    }
    return any ? Start::work : Start::converged;
  };
  auto stop = [&](SolveStatus status, const std::string& detail) {
    run.status = status;
    run.detail = "bicgstab: " + detail;
  };

  Start state = start();
  if (state == Start::nonfinite) stop(SolveStatus::nonfinite, "non-finite initial residual");
  for (long it = 1; state == Start::work && it <= cfg.max_iter; ++it) {
    const std::string where = " at iteration " + std::to_string(it);
    const Rgb rho = k.dot(RHAT, r);
    Rgb beta{0, 0, 0}, omega_v{0, 0, 0};
    std::string broke;
    for (int c = 0; c < 3; ++c) {
      if (!active[c]) continue;
      if (!(std::abs(rho[c]) > eps * std::sqrt(rhat2[c] * rr[c])))
        broke = std::string("rho = r^.r ~ 0 in channel ") + kChannel[c] + where;
      if (!fresh) {
        beta[c] = (rho[c] / rho_old[c]) * (alpha[c] / omega[c]);
        omega_v[c] = omega[c];
      }
    }
    if (!broke.empty()) {
      stop(SolveStatus::breakdown, broke);
      break;
    }
    k.axpby(P, negated(omega_v), V, one);  // p = r + β (p - ω v)
    k.axpby(P, one, r, beta);
    k.matvec(V, P, 1, -1, 0);  // v = A p
    ++run.matrix_passes;
    const Rgb rhat_v = k.dot(RHAT, V);
    for (int c = 0; c < 3; ++c) {
      alpha[c] = active[c] ? rho[c] / rhat_v[c] : 0;
      if (active[c] && !(rhat_v[c] != 0 && std::isfinite(alpha[c])))
        broke = std::string("r^.v ~ 0 in channel ") + kChannel[c] + where;
    }
    if (!broke.empty()) {
      stop(SolveStatus::breakdown, broke);
      break;
    }
    k.copy(s, r);  // s = r - α v
    k.axpby(s, negated(alpha), V, one);
    const Rgb ss = k.dot(s, s);
    k.matvec(T_, s, 1, -1, 0);  // t = A s
    ++run.matrix_passes;
    const Rgb ts = k.dot(T_, s), tt = k.dot(T_, T_);
    for (int c = 0; c < 3; ++c) {
      omega[c] = 0;
      // A channel whose s already meets tol takes the half step x += α p alone (ω = 0, so r = s).
      if (!active[c] || std::sqrt(ss[c]) / scale[c] <= cfg.tol) continue;
      omega[c] = ts[c] / tt[c];
      if (!(std::abs(ts[c]) > eps * std::sqrt(tt[c] * ss[c])))
        broke = std::string("omega = t.s/t.t ~ 0 in channel ") + kChannel[c] + where;
    }
    k.axpby(X, alpha, P, one);  // x += α p + ω s
    k.axpby(X, omega, s, one);
    k.axpby(s, negated(omega), T_, one);  // r = s - ω t
    std::swap(r, s);
    rr = k.dot(r, r);
    rho_old = rho;
    fresh = false;
    run.iterations = it;
    snapshots(it, X);

    bool finite = true, any = false;
    for (int c = 0; c < 3; ++c) {
      const double res = std::sqrt(rr[c]) / scale[c];
      finite = finite && std::isfinite(res) && std::isfinite(alpha[c]) && std::isfinite(omega[c]);
      active[c] = active[c] && res > cfg.tol;
      any = any || active[c];
    }
    if (!finite) {
      stop(SolveStatus::nonfinite, "non-finite residual" + where);
      break;
    }
    if (!broke.empty()) {  // x and r took this iteration's step; the next β would divide by ω
      stop(SolveStatus::breakdown, broke);
      break;
    }
    if (!any) {
      state = start();
      if (state == Start::nonfinite) stop(SolveStatus::nonfinite, "non-finite true residual" + where);
    }
  }
  if (state == Start::converged) run.status = SolveStatus::converged;
  run.callback_s = snapshots.seconds();
  return run;
}

template MethodRun bicgstab(Kernels<float>&, const Rgb&, const SolveConfig&, const IterationCallback&);
template MethodRun bicgstab(Kernels<double>&, const Rgb&, const SolveConfig&, const IterationCallback&);

}  // namespace radiosity
