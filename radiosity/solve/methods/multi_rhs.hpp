// Jacobi on k right-hand sides at once (the light basis, radiosity/relight/basis.hpp), written once over the
// k-right-hand-side contract (kernels.hpp's MultiKernels): B_q ← E_q + ρ ⊙ F B_q for every q in one pass over F per
// step, until every right-hand side's every channel has a relative residual ‖E_q - A B_q‖ / scale_q,c <= cfg.tol
// (scale: ‖E_q,c‖₂, or 1 where E_q,c = 0). A step's product gives the residual of the iterate it starts from
// (Y - X = E - A X), so the answer is that iterate and `iterations` counts the steps before it.
#pragma once
#include <string>
#include <vector>

#include "radiosity/solve/config/config.hpp"
#include "radiosity/solve/contract/kernels.hpp"

namespace radiosity {

inline constexpr int kMultiJacobiVectors = 2;  // slot 0 starts as E (the contract's), slot 1 is the next iterate

struct MultiMethodRun {
  long iterations = 0;
  SolveStatus status = SolveStatus::max_iter;  // converged | max_iter | nonfinite
  std::string detail;
  double worst = 0;  // the largest relative residual over right-hand sides and channels, of the answer
  long matrix_passes = 0;
  int answer = 0;    // the slot that holds the answer
};

// scale[q]: per channel ‖E_q,c‖₂ (1 where 0). Stops at cfg.tol, or after cfg.max_iter steps (status max_iter,
// `worst` the residual then), or at a non-finite residual (status nonfinite).
template <class T>
MultiMethodRun multi_jacobi(MultiKernels<T>& k, const std::vector<Rgb>& scale, const SolveConfig& cfg);

}  // namespace radiosity
