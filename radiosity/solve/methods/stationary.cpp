#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "radiosity/solve/methods/divergence.hpp"
#include "radiosity/solve/methods/methods.hpp"

namespace radiosity {

namespace {

constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

// The norms of an iterate b (in slot b; the one before it in slot before, or -1): the step from it always, the
// O(n) norms beyond the step's own only for the history or for a rule that needs them.
template <class T>
struct IterateMeasure {
  Kernels<T>& k;
  bool norms_b, norms_inf;

  IterateNorms operator()(long iteration, int b, int before) const {
    const Rgb unknown{kUnknown, kUnknown, kUnknown};
    IterateNorms m;
    m.iteration = iteration;
    m.res2 = unknown;
    m.step2 = before < 0 ? unknown : k.dist2(b, before);
    m.step_inf = before >= 0 && norms_inf ? k.max_abs_diff(b, before) : unknown;
    m.b2 = norms_b ? k.dot(b, b) : unknown;
    m.b_inf = norms_inf ? k.max_abs(b) : unknown;
    return m;
  }
};

// The run's end when step `step` went wrong: non-finite numbers, divergence against the first residual, or (with
// a tolerance) a residual that no longer moves far above it (divergence.hpp). res: the relative residual of
// b_{step-1}; cur and nxt: the slots of b_{step-1} and b_step. Returns false (run untouched) while none is.
bool ended_badly(MethodRun& run, const SolveConfig& cfg, long step, bool finite, const Rgb& first, const Rgb& res,
                 Stagnation& stagnation, int cur, int nxt) {
  const std::string diverged = finite ? divergence(first, res) : "";
  if (!finite || !diverged.empty()) {
    run.status = finite ? SolveStatus::divergent : SolveStatus::nonfinite;
    run.detail = to_string(cfg.method) + ": " + (finite ? diverged : "non-finite radiosity or residual") + " at step " +
                 std::to_string(step);
    run.iterations = step;
    run.answer = nxt;
    return true;
  }
  if (cfg.steps > 0) return false;
  const std::string stuck = stagnation(step, res);
  if (stuck.empty()) return false;
  run.status = SolveStatus::stagnant;
  run.detail = stuck.substr(0, 13) + to_string(cfg.method) + ": " + stuck.substr(13) +
               " (the iteration makes no progress: (I - ρF) B = E has no solution it can reach, as for a "
               "closed scene that loses no light)";
  run.iterations = step - 1;  // b_{step-1}, whose residual it is
  run.answer = cur;
  return true;
}

}  // namespace

template <class T>
MethodRun stationary(Kernels<T>& k, const Rgb& e2, const SolveConfig& cfg, const IterationCallback& callback) {
  MethodRun run;
  Snapshots<T> snapshots(k, callback);
  const StopRule& rule = cfg.stop;
  const bool fixed = cfg.steps > 0;
  const bool jacobi = cfg.method == Method::jacobi;
  const double omega = cfg.method == Method::sor ? cfg.omega : 1.0;
  const IterateMeasure<T> measure{k, cfg.history || (!fixed && rule.needs_b()),
                                  cfg.history || (!fixed && rule.base == StopRule::Base::step_inf)};
  // A residual rule checks b_{step-1} at step `step` (its residual comes with the step), so with a tolerance step
  // max_iter + 1 is only computed as the check of b_max_iter; a step rule checks b_step itself.
  const long last = fixed ? cfg.steps : cfg.max_iter + (rule.on_step() ? 0 : 1);
  run.status = fixed ? SolveStatus::steps_done : SolveStatus::max_iter;
  Rgb scale;
  for (int c = 0; c < 3; ++c) scale[c] = e2[c] == 0 ? 1.0 : std::sqrt(e2[c]);
  int cur = 0, nxt = 1;
  IterateNorms prev = measure(0, cur, -1), now;  // b_{step-1} and b_step
  bool kept_last = false;                        // whether the history holds the newest iterate
  auto keep = [&](const IterateNorms& m) {
    if (cfg.history) run.history.push_back(m);
  };
  Rgb first{0, 0, 0};  // the residual of b_0, which divergence is measured against
  Stagnation stagnation(cfg.tol, cfg.precision == Precision::double_);
  for (long step = 1; step <= last; ++step) {
    // Jacobi: b_step - b_{step-1} = e - A b_{step-1}, so the residual of the previous iterate comes with the step
    // for O(n). Gauss-Seidel and SOR: the sweep sums every row against b_{step-1} as well and returns its residual.
    // Either way a residual rule's answer is b_{step-1}, one step short of the newest, whose step was its check.
    Rgb res2;
    if (jacobi) {
      k.matvec(nxt, cur, 0, 1, 1);  // b_step = e + ρ ⊙ F b_{step-1}
      now = measure(step, nxt, cur);
      res2 = now.step2;
    } else {
      res2 = k.sor_sweep(nxt, cur, omega);
      now = measure(step, nxt, cur);
    }
    ++run.matrix_passes;
    prev.res2 = res2;
    if (step == 1) run.r0_2 = res2;
    keep(prev);
    Rgb res;
    bool finite = true;
    for (int c = 0; c < 3; ++c) {
      res[c] = std::sqrt(res2[c]) / scale[c];
      finite = finite && std::isfinite(res[c]) && std::isfinite(now.step2[c]);
    }
    if (step == 1) first = res;
    // A residual rule decides on b_{step-1}, a step rule on b_step.
    const IterateNorms& judged = rule.on_step() ? now : prev;
    const bool bad = ended_badly(run, cfg, step, finite, first, res, stagnation, cur, nxt);
    const bool met = !bad && !fixed && rule.value(judged, e2, run.r0_2) <= cfg.tol;
    if (bad || (!fixed && (met || step == last))) {
      if (!bad) {
        run.status = met ? SolveStatus::converged : SolveStatus::max_iter;
        run.iterations = rule.on_step() ? step : step - 1;
        run.answer = rule.on_step() ? nxt : cur;
      }
      keep(now);  // a residual rule: b_step, its residual unknown; the history says how far the run went
      kept_last = true;
      break;
    }
    std::swap(cur, nxt);
    run.iterations = step;
    run.answer = cur;
    prev = now;
    snapshots(step, cur);
  }
  if (!kept_last) keep(prev);  // fixed steps: the last iterate, its residual unknown
  run.callback_s = snapshots.seconds();
  return run;
}

template MethodRun stationary(Kernels<float>&, const Rgb&, const SolveConfig&, const IterationCallback&);
template MethodRun stationary(Kernels<double>&, const Rgb&, const SolveConfig&, const IterationCallback&);

}  // namespace radiosity
