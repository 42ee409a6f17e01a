// The iterative methods, written once over the Kernels<T> of any backend (report §3.7). Each channel c solves
// A_c b_c = e_c; the three run in lock-step so that every pass over F serves all of them. The residual of a
// channel is ‖e_c - A_c b_c‖₂ / scale_c with scale = residual_scale(system) (‖e_c‖₂, or 1 where e_c = 0).
#pragma once
#include <string>
#include <vector>

#include "common/timer.hpp"
#include "radiosity/solve/contract/kernels.hpp"
#include "radiosity/solve/config/config.hpp"

namespace radiosity {

// Vector slots each method needs; slot 0 holds B0 on entry.
inline constexpr int kJacobiVectors = 2;  // also Gauss-Seidel and SOR
inline constexpr int kBicgstabVectors = 8;

struct MethodRun {
  long iterations = 0;
  SolveStatus status = SolveStatus::max_iter;
  std::string detail;
  long matrix_passes = 0;
  int answer = 0;         // the slot that holds the B to return
  double callback_s = 0;  // time spent fetching B for the callback and in it
  std::vector<IterateNorms> history;  // cfg.history
  Rgb r0_2{0, 0, 0};
};

// Jacobi (b_k = e + ρ ⊙ F b_{k-1}), Gauss-Seidel and SOR (Kernels::sor_sweep) share one loop (stationary.cpp):
// b_k from b_{k-1} by one pass over F, which also gives the residual of b_{k-1}. cfg.steps steps exactly (RRV), or
// until the stopping rule is met; either way it stops early, status nonfinite or divergent (divergence.hpp), when
// the numbers go wrong. e2 = ‖e‖² per channel.
template <class T>
MethodRun stationary(Kernels<T>& k, const Rgb& e2, const SolveConfig& cfg, const IterationCallback& callback);

// BiCG-STAB (van der Vorst 1992) on each channel, until the stopping rule is met (a full iteration, two
// products, counts one).
template <class T>
MethodRun bicgstab(Kernels<T>& k, const Rgb& e2, const SolveConfig& cfg, const IterationCallback& callback);

// Hands B_k to the caller's callback and keeps the time that took out of the solve time.
template <class T>
class Snapshots {
 public:
  Snapshots(Kernels<T>& k, const IterationCallback& callback) : k_(k), callback_(callback) {}
  void operator()(long iteration, int slot) {
    if (!callback_) return;
    hpcgi::Timer t;
    k_.download(slot, buf_);
    callback_(iteration, buf_);
    seconds_ += t.seconds();
  }
  double seconds() const { return seconds_; }

 private:
  Kernels<T>& k_;
  const IterationCallback& callback_;
  std::vector<Rgb> buf_;
  double seconds_ = 0;
};

}  // namespace radiosity
