#include <cmath>
#include <string>
#include <utility>

#include "radiosity/solve/divergence.hpp"
#include "radiosity/solve/methods.hpp"

namespace radiosity {

template <class T>
MethodRun jacobi(Kernels<T>& k, const Rgb& scale, const SolveConfig& cfg, const IterationCallback& callback) {
  MethodRun run;
  Snapshots<T> snapshots(k, callback);
  const bool fixed = cfg.steps > 0;
  // With a tolerance, step max_iter + 1 is only computed as the residual check of b_max_iter (see below).
  const long last = fixed ? cfg.steps : cfg.max_iter + 1;
  run.status = fixed ? SolveStatus::steps_done : SolveStatus::max_iter;
  int cur = 0, nxt = 1;
  Rgb first{0, 0, 0};  // the residual of b_0, which divergence is measured against
  for (long step = 1; step <= last; ++step) {
    k.matvec(nxt, cur, 0, 1, 1);  // b_step = e + ρ ⊙ F b_{step-1}
    ++run.matrix_passes;
    // b_step - b_{step-1} = e - A b_{step-1}: the residual of the previous iterate comes with the step for O(n),
    // so the tolerance costs no extra pass over F. The price: the answer is b_{step-1}, one step short of the
    // newest iterate, and the step that found it converged was spent as its check.
    const Rgb d2 = k.dist2(nxt, cur);
    Rgb res;
    bool finite = true, met = true;
    for (int c = 0; c < 3; ++c) {
      res[c] = std::sqrt(d2[c]) / scale[c];
      finite = finite && std::isfinite(res[c]);
      met = met && res[c] <= cfg.tol;
    }
    if (step == 1) first = res;
    const std::string diverged = finite ? divergence(first, res) : "";
    if (!finite || !diverged.empty()) {
      run.status = finite ? SolveStatus::divergent : SolveStatus::nonfinite;
      run.detail = "jacobi: " + (finite ? diverged : "non-finite radiosity or residual") + " at step " +
                   std::to_string(step);
      run.iterations = step;
      run.answer = nxt;
      break;
    }
    if (!fixed && (met || step == last)) {
      run.status = met ? SolveStatus::converged : SolveStatus::max_iter;
      run.iterations = step - 1;
      run.answer = cur;
      break;
    }
    std::swap(cur, nxt);
    run.iterations = step;
    run.answer = cur;
    snapshots(step, cur);
  }
  run.callback_s = snapshots.seconds();
  return run;
}

template MethodRun jacobi(Kernels<float>&, const Rgb&, const SolveConfig&, const IterationCallback&);
template MethodRun jacobi(Kernels<double>&, const Rgb&, const SolveConfig&, const IterationCallback&);

}  // namespace radiosity
