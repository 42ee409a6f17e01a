#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "radiosity/solve/methods/methods.hpp"

namespace radiosity {
namespace {

const char* const kChannel[3] = {"r", "g", "b"};

Rgb negated(const Rgb& a) { return {-a[0], -a[1], -a[2]}; }

}  // namespace

// Three scalar recurrences, one per channel, share every kernel call. A channel that meets the stopping rule is
// frozen by giving it α = ω = β = 0 (then x and r stay as they are), so it neither moves nor breaks down while
// the others go on (a stacked rule freezes all three at once). When every channel meets a residual rule by the
// recurrence's residual, the true residual e - A x is computed; a channel that rounding left short (float)
// restarts from it, with r̂ = r. A step rule (‖x_k - x_{k-1}‖) is met on the iteration's step alone.
template <class T>
MethodRun bicgstab(Kernels<T>& k, const Rgb& e2, const SolveConfig& cfg, const IterationCallback& callback) {
  enum Slot { X = 0, RHAT, P, V, T_, R_A, R_B, X_OLD };
  constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();
  const Rgb unknown{kUnknown, kUnknown, kUnknown};
  const StopRule& rule = cfg.stop;
  const bool steps_needed = cfg.history || rule.on_step();
  const bool norms_b = cfg.history || rule.needs_b();
  const bool norms_inf = cfg.history || rule.base == StopRule::Base::step_inf;
  Rgb scale;
  for (int c = 0; c < 3; ++c) scale[c] = e2[c] == 0 ? 1.0 : std::sqrt(e2[c]);
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
  bool started = false;
  // The norms of x_it: the residual rr (the recurrence's, or the true one after a (re)start) and, where needed, the
  // step from x_{it-1} (in X_OLD) and x's own norms.
  IterateNorms norms;
  auto measure = [&](long it, bool with_step) {
    norms.iteration = it;
    norms.res2 = rr;
    norms.step2 = with_step && steps_needed ? k.dist2(X, X_OLD) : unknown;
    norms.step_inf = with_step && steps_needed && norms_inf ? k.max_abs_diff(X, X_OLD) : unknown;
    norms.b2 = norms_b ? k.dot(X, X) : unknown;
    norms.b_inf = norms_inf ? k.max_abs(X) : unknown;
  };
  auto met = [&](int c) { return rule.values(norms, e2, run.r0_2)[c] <= cfg.tol; };

  enum class Start { work, converged, nonfinite };
  auto start = [&]() {
    k.matvec(r, X, -1, 1, 1);  // r = e - A x
    ++run.matrix_passes;
    k.copy(RHAT, r);
    rr = k.dot(r, r);
    rhat2 = rr;
    rho_old = alpha = omega = one;
    fresh = true;
    if (!started) {
      run.r0_2 = rr;
      measure(0, false);
      if (cfg.history) run.history.push_back(norms);
      started = true;
    } else {  // a restart at x_it: the true residual replaces the recurrence's in the decision and the history
      norms.res2 = rr;
      if (cfg.history) run.history.back() = norms;
    }
    bool any = false;
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(std::sqrt(rr[c]) / scale[c])) return Start::nonfinite;
      // A step rule cannot be met without a step (and it is never restarted): every channel takes an iteration.
      active[c] = rule.on_step() || !met(c);
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
    // A channel whose s already meets a residual rule takes the half step x += α p alone (ω = 0, so r = s) and is
    // done (the rule's other norms are those of the last iterate).
    bool half[3] = {false, false, false};
    if (!rule.on_step()) {
      IterateNorms at_s = norms;
      at_s.res2 = ss;
      const Rgb v = rule.values(at_s, e2, run.r0_2);
      for (int c = 0; c < 3; ++c) half[c] = active[c] && v[c] <= cfg.tol;
    }
    for (int c = 0; c < 3; ++c) {
      omega[c] = 0;
      if (!active[c] || half[c]) continue;
      omega[c] = ts[c] / tt[c];
      if (!(std::abs(ts[c]) > eps * std::sqrt(tt[c] * ss[c])))
        broke = std::string("omega = t.s/t.t ~ 0 in channel ") + kChannel[c] + where;
    }
    if (steps_needed) k.copy(X_OLD, X);
    k.axpby(X, alpha, P, one);  // x += α p + ω s
    k.axpby(X, omega, s, one);
    k.axpby(s, negated(omega), T_, one);  // r = s - ω t
    std::swap(r, s);
    rr = k.dot(r, r);
    rho_old = rho;
    fresh = false;
    run.iterations = it;
    measure(it, true);
    if (cfg.history) run.history.push_back(norms);
    snapshots(it, X);

    bool finite = true, any = false;
    for (int c = 0; c < 3; ++c) {
      const double res = std::sqrt(rr[c]) / scale[c];
      finite = finite && std::isfinite(res) && std::isfinite(alpha[c]) && std::isfinite(omega[c]);
      active[c] = active[c] && !half[c] && !met(c);
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
    if (!any && rule.on_step()) state = Start::converged;
    if (!any && !rule.on_step()) {
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
