// Phase 1 of `bin/radiosity solve` (solve_cmd.cpp): the plan, the one place that refuses a request. Every rule
// about what was asked is checked here once, on every MPI rank alike, before anything is read: the options'
// combinations that CLI11 cannot see (solve_options.cpp checks those that depend on which options were given),
// the files, the picture, the snapshots, the backend and its configuration (the library's check_config, the
// one statement of what a backend runs, of the tolerance and of omega) and what the backend reads (the library's
// require_storage). A sparse form-factor file's own rules are
// checked when its header is read (plan_sparse_file, called by the load).
#pragma once
#include <optional>
#include <string>

#include "radiosity/app/commands.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity::app {

struct SolvePlan {
  SolveConfig cfg;                      // as given, with --threads
  const SolveBackend* backend = nullptr;
  FFValues values = FFValues::float32;  // --ff-precision
  std::optional<FFStorage> storage;     // --storage; none: auto (chosen when the kept values are counted)
  double limit = 0;                     // --max-memory-per-rank in bytes, 0: none
  int width = 0, height = 0;            // --size
  int ranks = 1, rank = 0;              // MPI (1, 0 without)
  bool root = true;                     // rank 0: prints and writes
  bool dist = false;                    // the backend runs on MPI ranks
};

// Throws hpcgi::UsageError (agreed by every rank) for a request that cannot run as asked.
SolvePlan plan_solve(const SolveArgs& a);

// A sparse form-factor file is solved as it is stored: by a backend that reads any storage, in its own storage and
// values, at its own threshold.
void plan_sparse_file(const SolveArgs& a, const SolveBackend& b, const FormFactorFileInfo& info);

// The picture of iteration k asked for by --snapshots.
std::string snapshot_file(const SolveArgs& a, long k);

}  // namespace radiosity::app
