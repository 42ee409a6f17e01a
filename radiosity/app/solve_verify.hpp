// Phase 4 of `bin/radiosity solve` (solve_cmd.cpp): the verification. The float64 check of the run (BabelStream's
// check_solution) and the error reference it is measured against (reference.hpp), and the outcome of the run as an
// exit status (common/errors.hpp). The error reference is a phase of its own: where it is solved is decided by one
// function here, solve_reference_at, which run_solve calls between the load's steps (where memory asks for it
// sooner than the run) and the verification after the run.
#pragma once
#include <string>

#include "common/errors.hpp"
#include "radiosity/app/reference.hpp"
#include "radiosity/app/solve_load.hpp"

namespace radiosity::app {

// The agreement check of a run: the same method on the run's own system, the form factors as the run stored them
// (threshold, 16-bit values, storage), in float64, AOS, backend openmp (which agrees bit for bit with serial), three
// channels: a fixed-step run against the same steps, where only rounding may differ; a run that stops on a
// tolerance against the converged solution, from which it may differ by about tol times the condition number of
// I - diag(ρ)F, at most (1 + ρ)/(1 - ρ) ≈ 19 for ρ ≤ 0.9. `converged` is that solution when the caller has it
// already (null: computed here).
struct Verification {
  double max_rel_diff = 0, bound = 0, seconds = 0;
  long reference_iterations = 0;
  bool agreed = false;
};
Verification verify(const System& sys, const SolveConfig& cfg, const SolveResult& res, const ErrorReference* converged);

// The points of a solve at which its error reference can be solved: before the run's own form factors are read
// (the load; --reference-ff's, so that the two are never held at once), before the load thresholds or rounds the
// file's values (the load; they are gone after), after the run (the verification; on the run's own matrix).
enum class ReferencePoint { before_form_factors, before_rounding, after_run };
// The error reference of a run, once solved.
struct References {
  ErrorReference ref;
  bool have = false;
  bool from_file = false;  // --reference-ff's (before_form_factors), not the run's own form factors
};
// Solves R.ref (agreed by the ranks) if `at` is where this run's reference is due: the one statement of where.
// Nothing with --no-verify or once it is solved; before_rounding and after_run once read_form_factors has set
// L.same_matrix.
void solve_reference_at(ReferencePoint at, const SolvePlan& p, const Loaded& L, References& R);

// What the verification made of a run (made: false with --no-verify or a failed run, which is not checked).
struct Checked {
  bool made = false;
  ErrorReference ref;  // the error reference (empty when none was solved)
  Verification v;
  double error = 0;  // the run's max relative difference from the error reference
  hpcgi::Outcome outcome;
};
// Checks the run (solving the reference where it is not yet) and says its outcome; the reference goes into Checked.
Checked verify_solve(const SolvePlan& p, const Loaded& L, References&& R, const SolveResult& res);

// The exit status of a solve (common/errors.hpp): 3 its numbers went wrong, 4 it stopped at --max-iter, 5 its
// float64 check (v: null when not made) disagreed, else 0.
hpcgi::Outcome outcome_of(const SolveResult& res, const SolveConfig& cfg, const Verification* v);

}  // namespace radiosity::app
