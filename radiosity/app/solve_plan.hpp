// Phase 1 of `bin/radiosity solve` (solve_cmd.cpp): the plan, the one place that refuses a request. Every rule
// about what was asked is checked here once, on every MPI rank alike, before anything is read: the options'
// combinations that CLI11 cannot see (solve_options.cpp checks those that depend on which options were given),
// the files, the picture, the snapshots, the backend and its configuration (the library's check_config, the
// one statement of what a backend runs, of the tolerance and of omega), what the backend reads (the library's
// require_storage) and the --ff file's header, read here once, with a sparse file's own rules (plan_sparse_file).
// The load checks that header against the mesh, and never comes back here.
#pragma once
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "radiosity/app/commands.hpp"
#include "radiosity/formfactor/file/file.hpp"
#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity::app {

// What a solve was asked, typed: the only reader of SolveArgs. Every later phase (load, run, verify, report) reads
// this, never the options.
struct SolvePlan {
  // What runs.
  SolveConfig cfg;                        // as given, with --threads
  const SolveBackend* backend = nullptr;  // cfg.backend's registry row: its facts, never its name, decide
  double min_time = 0;                    // --min-time: a short solve repeated (common/repetitions.hpp)
  // The scene: its file, --divide and the other load options, --threads, and the record's options (--record, --json,
  // --quiet).
  SceneArgs scene;
  // The form factors.
  std::string ff;                       // --ff
  // --ff opened, its header read once and checked for what it says of itself, and a sparse file's rules
  // (plan_sparse_file) applied; none where --ff is no regular file (the load refuses it by what it is).
  std::optional<FormFactorFile> file;
  FFValues values = FFValues::float32;  // --ff-precision
  std::optional<FFStorage> storage;     // --storage; none: auto (chosen when the kept values are counted)
  double threshold = 0;                 // --threshold: |F_ij| <= it dropped at load
  // The error reference and the float64 check.
  bool verify = true;           // not --no-verify
  std::string reference_ff;     // --reference-ff (empty: --ff's)
  double reference_divide = 0;  // --reference-divide (0: the run's mesh)
  // What is written besides the record.
  std::string output_xml, png, view;               // --output, --png, --view
  int width = 0, height = 0;                       // --size
  double exposure = 1;                             // --exposure
  std::vector<std::pair<long, std::string>> snapshots;  // --snapshots: the iterations and their pictures
  // Where it runs.
  double limit = 0;          // --max-memory-per-rank in bytes, 0: none
  int ranks = 1, rank = 0;   // MPI (1, 0 without)
  bool root = true;          // rank 0: prints and writes
  bool dist = false;         // the backend runs on MPI ranks
};

// Throws hpcgi::UsageError (agreed by every rank) for a request that cannot run as asked.
SolvePlan plan_solve(const SolveArgs& a);

// A sparse form-factor file is solved as it is stored: by a backend that reads any storage, in its own storage and
// values, at its own threshold.
void plan_sparse_file(const SolvePlan& p, const FormFactorFileInfo& info);

// The picture of iteration k asked for by --snapshots (prefix: --snapshot-prefix, empty: "snapshot").
std::string snapshot_file(const std::string& prefix, long k);

}  // namespace radiosity::app
