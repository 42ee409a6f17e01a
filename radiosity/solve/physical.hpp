// The one physical check of a radiosity answer, run on every path that returns radiosities: solve() (every method,
// layout, precision, storage and backend, MPI and the GPU ones included), the light basis (solve_multi) and the
// relit frames.
//
// With emission and reflectivity non-negative, the radiosity is the sum of the light's bounces,
// B = E + ρF E + (ρF)² E + ..., so B ≥ E wherever an answer exists. Where ρF has spectral radius 1 or more that
// series diverges and there is no physical answer, while (I - ρF) B = E may still have an algebraic solution, which
// is then negative somewhere (Perron-Frobenius: a non-negative B with ρF B ≤ B needs spectral radius ≤ 1).
// For any B, B_i - E_i = ρ_i (F B)_i + r_i with r = E - (I - ρF) B: a non-negative answer cannot fall below E by
// more than its residual. So the check allows, per channel, the residual the answer reached (its recomputed relative
// residual, or the tolerance where that is larger, times the residual's scale ‖e_c‖) and the rounding of the
// working precision at that patch; a B below E beyond that is no answer.
#pragma once
#include <string>
#include <vector>

#include "radiosity/solve/config/config.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

struct PhysicalCheck {
  SolveStatus status = SolveStatus::converged;  // converged: physical; nonfinite or unphysical otherwise
  std::string detail;                           // one line: the patch, the channel, the smallest B - E, why
  double min_margin = 0;                        // the smallest (B - E) + allowance over patches and channels
};

// Checks B against sys's emission. rel_residual: the answer's recomputed relative residual per channel; tol: the
// tolerance it was asked (0 for fixed steps); working: the precision its sums were made in.
PhysicalCheck check_physical(const System& sys, const std::vector<Rgb>& B, const Rgb& rel_residual, double tol,
                             Precision working);

// Applies check_physical to a result that is an answer so far (not failed): on a violation its status becomes
// nonfinite or unphysical with the one line as its detail. Returns whether it passed.
bool require_physical(const System& sys, SolveResult& res, double tol, Precision working);

}  // namespace radiosity
