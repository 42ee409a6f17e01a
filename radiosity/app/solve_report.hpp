// Phase 5 of `bin/radiosity solve` (solve_cmd.cpp): the report. The run's record (its fields are read by
// analysis/ and compared across machines: their names and values are the record's contract), the printed summary,
// and the solved scene and picture of a run that is an answer.
#pragma once
#include <nlohmann/json.hpp>

#include "radiosity/app/solve_run.hpp"
#include "radiosity/app/solve_verify.hpp"

namespace radiosity::app {

// Everything the report says, from the phases before it.
struct SolveReport {
  const SolvePlan& p;
  const Loaded& L;
  const SolveRun& run;
  const Checked& c;
  double total_s;  // since the run began
};

// The record (collective under MPI: every rank builds it, rank 0 writes it).
nlohmann::json solve_record(const SolveReport& r);
// The history of a run (--history): per iterate k = 0, 1, ... its norms as the method measured them (res2, step2,
// b2: squares of 2-norms per channel; step_inf, b_inf: ∞-norms; null where not known), from which
// analysis/table42_audit.py replays any stopping rule, the run's rule value, and the relative measures
// ‖e - A b‖₂/‖e‖₂, ‖Δb‖₂/‖b‖₂, ‖Δb‖∞/‖b‖∞ per channel (rel_*) and over the stacked channels (rel_*_stacked).
nlohmann::json history_json(const SolveResult& res, const SolveConfig& cfg);
// The printed summary (rank 0, without --quiet).
void print_summary(const SolveReport& r);
// Rank 0: the scene and picture of a run that is an answer, the snapshots' names, the record; then every rank
// ends with the run's exit status.
void finish_solve(const SolveReport& r, const nlohmann::json& rec);

}  // namespace radiosity::app
