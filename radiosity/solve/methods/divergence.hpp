// When a Jacobi-type iteration b_k = e + ρ ⊙ F b_{k-1} diverges, judged by its residual per channel (the 2-norm of
// b_k - b_{k-1}), so that it stops with status divergent instead of running to max_iter or overflowing; and when it
// stagnates (Stagnation, below), so that it stops with status stagnant.
//
// Why a fixed factor is safe: if every row of ρF sums to at most 1 (ρ <= 1 and a physical F, whose rows sum to at
// most 1), the residual r_k = (ρF) r_{k-1} never grows in the max-norm, so ‖r_k‖₂ <= √n ‖r_k‖∞ <= √n ‖r_1‖₂.
// A residual more than kDivergenceFactor times its first value, 10·√n at the scene loader's 2^20 patches, is
// therefore impossible for such a system: some row of ρF sums above 1, and the iterates only grow.
#pragma once
#include <algorithm>
#include <cfloat>
#include <cstdio>
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

inline constexpr double kDivergenceFactor = 1e4;

// The first channel whose residual exceeds kDivergenceFactor times its first value, with the factor, as a
// sentence for SolveResult::detail; empty while none does. `first` and `now` are residual norms per channel.
inline std::string divergence(const Rgb& first, const Rgb& now) {
  static const char* const channel[3] = {"r", "g", "b"};
  for (int c = 0; c < 3; ++c)
    if (now[c] > kDivergenceFactor * first[c]) {
      char growth[64];
      std::snprintf(growth, sizeof growth, "%.3g times its first value %.3g", now[c] / first[c], first[c]);
      return std::string("the residual in channel ") + channel[c] + " grew to " + growth +
             " (some row of reflectivity x form factors sums above 1)";
    }
  return {};
}

// Stagnation of a run with a tolerance: over the last kStagnationWindow steps its largest relative residual
// ‖e - A b‖/‖e‖ did not decrease (no step of the window fell below its first value, nor its middle below its first,
// nor its last below its middle, by more than the relative kStagnationBand: float 1e-3, double 1e-6), while far
// above the tolerance (over 1000 × tol and 10⁴ × the working precision's epsilon, so that a residual held up by
// rounding near the tolerance runs on to max_iter instead). A convergent iteration at rate q falls by 1 - q^50 per
// half window: every q below 1 - 2e-5 (float; double: 1 - 2e-8) is not stagnant, nor is a transient growth with
// its decrease after it (the last half falls). The lossless closed box (ρ = 1, rows of F summing to 1) is the case:
// B grows by E every step, the residual stays at its first value (or grows, where rows sum a little above 1), and
// (I - ρF) B = E has no solution.
inline constexpr long kStagnationWindow = 100;

class Stagnation {
 public:
  Stagnation(double tol, bool double_precision)
      : tol_(tol),
        band_(double_precision ? 1e-6 : 1e-3),
        floor_(std::max(1e3 * tol, 1e4 * (double_precision ? DBL_EPSILON : double(FLT_EPSILON)))) {}

  // The relative residuals of step `step` per channel; returns the detail, starting "no solution: ", once the run
  // has stagnated (empty until then).
  std::string operator()(long step, const Rgb& residual) {
    last_.push_back(std::max({residual[0], residual[1], residual[2]}));
    if (long(last_.size()) > kStagnationWindow) last_.erase(last_.begin());
    if (long(last_.size()) < kStagnationWindow) return {};
    const double first = last_.front(), middle = last_[last_.size() / 2], now = last_.back();
    const double low = *std::min_element(last_.begin() + 1, last_.end());
    const double keep = 1 - band_;
    if (!(low > floor_) || low < keep * first || middle < keep * first || now < keep * middle) return {};
    char what[256];
    std::snprintf(what, sizeof what,
                  "the relative residual did not decrease over the last %ld steps (%.4g at step %ld, %.4g at step "
                  "%ld), far above the tolerance %.1e",
                  kStagnationWindow, first, step - kStagnationWindow + 1, now, step, tol_);
    return std::string("no solution: ") + what;
  }

 private:
  double tol_, band_, floor_;
  std::vector<double> last_;
};

}  // namespace radiosity
