#include "radiosity/solve/methods/multi_rhs.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace radiosity {

template <class T>
MultiMethodRun multi_jacobi(MultiKernels<T>& k, const std::vector<Rgb>& scale, const SolveConfig& cfg) {
  MultiMethodRun run;
  int x = 0, y = 1;
  for (long step = 1;; ++step) {
    k.matvec(y, x, 0.0, 1.0, 1.0);  // Y = E + ρ ⊙ F X
    ++run.matrix_passes;
    // Y - X = E - A X: the residual of X, which is the answer once every right-hand side's is <= tol.
    const std::vector<Rgb> d2 = k.dist2(x, y);
    double worst = 0;
    for (size_t q = 0; q < d2.size(); ++q)
      for (int c = 0; c < 3; ++c) {
        const double r = std::sqrt(d2[q][c]) / scale[q][c];
        worst = std::isnan(r) ? r : std::max(worst, r);
      }
    run.worst = worst;
    run.answer = x;
    run.iterations = step - 1;
    if (!std::isfinite(worst)) {
      run.status = SolveStatus::nonfinite;
      run.detail = "non-finite radiosity at Jacobi step " + std::to_string(step);
      return run;
    }
    if (worst <= cfg.tol) {
      run.status = SolveStatus::converged;
      return run;
    }
    if (step > cfg.max_iter) {
      run.status = SolveStatus::max_iter;
      return run;
    }
    std::swap(x, y);
  }
}

template MultiMethodRun multi_jacobi(MultiKernels<float>&, const std::vector<Rgb>&, const SolveConfig&);
template MultiMethodRun multi_jacobi(MultiKernels<double>&, const std::vector<Rgb>&, const SolveConfig&);

}  // namespace radiosity
