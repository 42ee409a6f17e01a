#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "radiosity/solve/methods/methods.hpp"

namespace radiosity {
namespace {

const char* const kChannel[3] = {"r", "g", "b"};

Rgb negated(const Rgb& a) { return {-a[0], -a[1], -a[2]}; }

// Three scalar recurrences, one per channel, share every kernel call. A channel that meets the stopping rule is
// frozen by giving it α = ω = β = 0 (then x and r stay as they are), so it neither moves nor breaks down while
// the others go on (a stacked rule freezes all three at once). When every channel meets a residual rule by the
// recurrence's residual, the true residual e - A x is computed; a channel that rounding left short (float)
// restarts from it, with r̂ = r. A step rule (‖x_k - x_{k-1}‖) is met on the iteration's step alone.
template <class T>
class BiCgStab {
 public:
  BiCgStab(Kernels<T>& k, const Rgb& e2, const SolveConfig& cfg, const IterationCallback& callback)
      : k_(k), e2_(e2), cfg_(cfg), rule_(cfg.stop), snapshots_(k, callback) {
    for (int c = 0; c < 3; ++c) scale_[c] = e2[c] == 0 ? 1.0 : std::sqrt(e2[c]);
    run_.answer = X;
  }

  MethodRun solve() {
    Start state = start();
    if (state == Start::nonfinite) stop(SolveStatus::nonfinite, "non-finite initial residual");
    for (long it = 1; state == Start::work && it <= cfg_.max_iter; ++it)
      if (!iterate(it, state)) break;
    if (state == Start::converged) run_.status = SolveStatus::converged;
    run_.callback_s = snapshots_.seconds();
    return run_;
  }

 private:
  enum Slot { X = 0, RHAT, P, V, T_, R_A, R_B, X_OLD };
  enum class Start { work, converged, nonfinite };
  static constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

  // The norms of x_it: the residual rr (the recurrence's, or the true one after a (re)start) and, where needed, the
  // step from x_{it-1} (in X_OLD) and x's own norms.
  void measure(long it, bool with_step) {
    const Rgb unknown{kUnknown, kUnknown, kUnknown};
    norms_.iteration = it;
    norms_.res2 = rr_;
    norms_.step2 = with_step && steps_needed_ ? k_.dist2(X, X_OLD) : unknown;
    norms_.step_inf = with_step && steps_needed_ && norms_inf_ ? k_.max_abs_diff(X, X_OLD) : unknown;
    norms_.b2 = norms_b_ ? k_.dot(X, X) : unknown;
    norms_.b_inf = norms_inf_ ? k_.max_abs(X) : unknown;
  }
  bool met(int c) const { return rule_.values(norms_, e2_, run_.r0_2)[c] <= cfg_.tol; }
  void stop(SolveStatus status, const std::string& detail) {
    run_.status = status;
    run_.detail = "bicgstab: " + detail;
  }

  // r = e - A x, r̂ = r: the first start, or a restart at x_it whose true residual replaces the recurrence's in the
  // decision and the history.
  Start start() {
    k_.matvec(r_, X, -1, 1, 1);  // r = e - A x
    ++run_.matrix_passes;
    k_.copy(RHAT, r_);
    rr_ = k_.dot(r_, r_);
    rhat2_ = rr_;
    rho_old_ = alpha_ = omega_ = kOne;
    fresh_ = true;
    if (!started_) {
      run_.r0_2 = rr_;
      measure(0, false);
      if (cfg_.history) run_.history.push_back(norms_);
      started_ = true;
    } else {
      norms_.res2 = rr_;
      if (cfg_.history) run_.history.back() = norms_;
    }
    bool any = false;
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(std::sqrt(rr_[c]) / scale_[c])) return Start::nonfinite;
      // A step rule cannot be met without a step (and it is never restarted): every channel takes an iteration.
      active_[c] = rule_.on_step() || !met(c);
      any = any || active_[c];
    }
    return any ? Start::work : Start::converged;
  }

  // One iteration; false when it ended the run (breakdown, non-finite), with state left as it was.
  bool iterate(long it, Start& state) {
    const std::string where = " at iteration " + std::to_string(it);
    const Rgb rho = k_.dot(RHAT, r_);
    std::string broke = direction(rho, where);
    if (!broke.empty()) {
      stop(SolveStatus::breakdown, broke);
      return false;
    }
    bool half[3] = {false, false, false};
    broke = stabilise(where, half);
    rho_old_ = rho;
    fresh_ = false;
    run_.iterations = it;
    measure(it, true);
    if (cfg_.history) run_.history.push_back(norms_);
    snapshots_(it, X);
    return judge(where, half, broke, state);
  }

  // p = r + β (p - ω v), v = A p, α = ρ / r̂·v; returns why it broke down (ρ ~ 0, r̂·v ~ 0), empty if it did not.
  // Breakdown: ρ = r̂·r or ω = t·s/t·t whose cosine (r̂·r / ‖r̂‖‖r‖, t·s / ‖t‖‖s‖) is below the working
  // precision, or r̂·v exactly 0; the next α or β would be noise or infinite.
  std::string direction(const Rgb& rho, const std::string& where) {
    Rgb beta{0, 0, 0}, omega_v{0, 0, 0};
    std::string broke;
    for (int c = 0; c < 3; ++c) {
      if (!active_[c]) continue;
      if (!(std::abs(rho[c]) > kEps * std::sqrt(rhat2_[c] * rr_[c])))
        broke = std::string("rho = r^.r ~ 0 in channel ") + kChannel[c] + where;
      if (!fresh_) {
        beta[c] = (rho[c] / rho_old_[c]) * (alpha_[c] / omega_[c]);
        omega_v[c] = omega_[c];
      }
    }
    if (!broke.empty()) return broke;
    k_.axpby(P, negated(omega_v), V, kOne);  // p = r + β (p - ω v)
    k_.axpby(P, kOne, r_, beta);
    k_.matvec(V, P, 1, -1, 0);  // v = A p
    ++run_.matrix_passes;
    const Rgb rhat_v = k_.dot(RHAT, V);
    for (int c = 0; c < 3; ++c) {
      alpha_[c] = active_[c] ? rho[c] / rhat_v[c] : 0;
      if (active_[c] && !(rhat_v[c] != 0 && std::isfinite(alpha_[c])))
        broke = std::string("r^.v ~ 0 in channel ") + kChannel[c] + where;
    }
    return broke;
  }

  // s = r - α v, t = A s, ω = t·s / t·t, then x += α p + ω s and r = s - ω t (r and s trade slots). A channel whose
  // s already meets a residual rule takes the half step x += α p alone (ω = 0, so r = s; half[c]) and is done (the
  // rule's other norms are those of the last iterate). Returns why ω broke down, empty if it did not.
  std::string stabilise(const std::string& where, bool (&half)[3]) {
    k_.copy(s_, r_);  // s = r - α v
    k_.axpby(s_, negated(alpha_), V, kOne);
    const Rgb ss = k_.dot(s_, s_);
    k_.matvec(T_, s_, 1, -1, 0);  // t = A s
    ++run_.matrix_passes;
    const Rgb ts = k_.dot(T_, s_), tt = k_.dot(T_, T_);
    if (!rule_.on_step()) {
      IterateNorms at_s = norms_;
      at_s.res2 = ss;
      const Rgb v = rule_.values(at_s, e2_, run_.r0_2);
      for (int c = 0; c < 3; ++c) half[c] = active_[c] && v[c] <= cfg_.tol;
    }
    std::string broke;
    for (int c = 0; c < 3; ++c) {
      omega_[c] = 0;
      if (!active_[c] || half[c]) continue;
      omega_[c] = ts[c] / tt[c];
      if (!(std::abs(ts[c]) > kEps * std::sqrt(tt[c] * ss[c])))
        broke = std::string("omega = t.s/t.t ~ 0 in channel ") + kChannel[c] + where;
    }
    if (steps_needed_) k_.copy(X_OLD, X);
    k_.axpby(X, alpha_, P, kOne);  // x += α p + ω s
    k_.axpby(X, omega_, s_, kOne);
    k_.axpby(s_, negated(omega_), T_, kOne);  // r = s - ω t
    std::swap(r_, s_);
    rr_ = k_.dot(r_, r_);
    return broke;
  }

  // After the iteration's step: which channels go on; the run ends on non-finite numbers or an ω breakdown (x and
  // r took this iteration's step; the next β would divide by ω), converges on a step rule, or restarts on the true
  // residual when every channel met a residual rule. False when the run ended.
  bool judge(const std::string& where, const bool (&half)[3], const std::string& broke, Start& state) {
    bool finite = true, any = false;
    for (int c = 0; c < 3; ++c) {
      const double res = std::sqrt(rr_[c]) / scale_[c];
      finite = finite && std::isfinite(res) && std::isfinite(alpha_[c]) && std::isfinite(omega_[c]);
      active_[c] = active_[c] && !half[c] && !met(c);
      any = any || active_[c];
    }
    if (!finite) {
      stop(SolveStatus::nonfinite, "non-finite residual" + where);
      return false;
    }
    if (!broke.empty()) {
      stop(SolveStatus::breakdown, broke);
      return false;
    }
    if (!any && rule_.on_step()) state = Start::converged;
    if (!any && !rule_.on_step()) {
      state = start();
      if (state == Start::nonfinite) stop(SolveStatus::nonfinite, "non-finite true residual" + where);
    }
    return true;
  }

  static constexpr Rgb kOne{1, 1, 1};
  static constexpr double kEps = std::numeric_limits<T>::epsilon();
  Kernels<T>& k_;
  const Rgb& e2_;
  const SolveConfig& cfg_;
  const StopRule& rule_;
  const bool steps_needed_ = cfg_.history || rule_.on_step();
  const bool norms_b_ = cfg_.history || rule_.needs_b();
  const bool norms_inf_ = cfg_.history || rule_.base == StopRule::Base::step_inf;
  Rgb scale_;
  MethodRun run_;
  Snapshots<T> snapshots_;
  int r_ = R_A, s_ = R_B;  // r and s trade slots every iteration (r = s - ω t is computed in s's slot)
  Rgb rr_, rhat2_, rho_old_, alpha_, omega_;
  bool active_[3] = {false, false, false};
  bool fresh_ = true;  // first iteration after a (re)start: p = r
  bool started_ = false;
  IterateNorms norms_;
};

}  // namespace

template <class T>
MethodRun bicgstab(Kernels<T>& k, const Rgb& e2, const SolveConfig& cfg, const IterationCallback& callback) {
  return BiCgStab<T>(k, e2, cfg, callback).solve();
}

template MethodRun bicgstab(Kernels<float>&, const Rgb&, const SolveConfig&, const IterationCallback&);
template MethodRun bicgstab(Kernels<double>&, const Rgb&, const SolveConfig&, const IterationCallback&);

}  // namespace radiosity
