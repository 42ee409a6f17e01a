// When a Jacobi-type iteration b_k = e + ρ ⊙ F b_{k-1} diverges, judged by its residual per channel (the 2-norm of
// b_k - b_{k-1}), so that it stops with status divergent instead of running to max_iter or overflowing.
//
// Why a fixed factor is safe: if every row of ρF sums to at most 1 (ρ <= 1 and a physical F, whose rows sum to at
// most 1), the residual r_k = (ρF) r_{k-1} never grows in the max-norm, so ‖r_k‖₂ <= √n ‖r_k‖∞ <= √n ‖r_1‖₂.
// A residual more than kDivergenceFactor times its first value, 10·√n at the scene loader's 2^20 patches, is
// therefore impossible for such a system: some row of ρF sums above 1, and the iterates only grow.
#pragma once
#include <cstdio>
#include <string>

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

}  // namespace radiosity
