// Phase 2 of `bin/radiosity solve` (solve_cmd.cpp): the load. The scene, its mesh, the form factors of --ff in the
// one FormFactorMatrix (dense: every row, or an MPI rank's block; a sparse file as stored), the
// matrix the run solves (threshold, storage, precision) and the memory checks before anything is allocated. Its
// three steps return one Loaded, each from the one before; run_solve calls them in turn, and between them, where memory asks for it,
// the error reference's own phase (solve_verify.hpp: before the run's form factors are read, and before the file's
// values are thresholded or rounded). The load never calls it.
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "radiosity/app/distributed.hpp"
#include "radiosity/app/solve_plan.hpp"
#include "radiosity/dist/split.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity::app {

struct Loaded {
  Mesh m;
  size_t n = 0;
  double n2 = 0;          // n², the dense matrix's entries
  std::string patches;    // "N patches"
  double load_s = 0, ff_load_s = 0, ff_build_s = 0;
  std::optional<FormFactorFile> file;  // the plan's --ff, checked against the mesh (none: no regular file)
  FormFactorFileInfo file_info;        // its info; version 1: dense (or not a file), else sparse
  bool sparse_file = false;
  dist::RowBlock block;              // this process's rows
  std::vector<RankNeed> rank_needs;  // what each rank holds (the record's mpi section)
  double file_bytes = 0;             // the file's values this process holds
  HemicubeParams params;             // the file's hemicube
  // The one form-factor matrix: the file's values as read (dense: this process's rows), then the run's (threshold,
  // storage, precision), which replaces them. sys views it.
  std::unique_ptr<FormFactorMatrix> matrix;
  System sys;
  FFStorage storage = FFStorage::dense;
  size_t kept = 0, skipped_rows = 0;
  bool dropped = false;  // the threshold drops some of the file's values
  size_t bridges = 0;    // the chosen storage's: compressed's bridges
  RunCounts runs;        // and the runs storage's runs
  double matrix_storage_bytes = 0;
  double rank_read_s = 0, rank_checksum_s = 0, rank_chain_s = 0;  // backend mpi: this rank's read of its rows
  // The run's matrix is the file's values as read (nothing thresholded or rounded): a reference on them is the
  // run's own converged solution, and can wait for the run.
  bool same_matrix = false;
  double choose_s = 0;  // choosing the storage (counting the kept values), part of ff_build_s
};

// The load's steps, each taking the step before's value and returning its own. Each throws hpcgi::UsageError
// (agreed) for a scene or file that does not fit the request or the memory.
// The mesh: a Loaded without form factors.
Loaded load_mesh(const SolvePlan& p);
// The --ff file, its header read and checked once: memory, its values as stored in the one matrix, the storage the
// run will take (so same_matrix).
Loaded read_form_factors(const SolvePlan& p, Loaded&& mesh);
// The run's matrix from the file's values: threshold, storage, precision (the file's values are given back).
Loaded build_matrix(const SolvePlan& p, Loaded&& read);
// The three in turn, for a caller that takes no error reference between them.
Loaded load_solve(const SolvePlan& p);

// The bytes in GiB, as the memory messages say them.
std::string gib(double bytes);
// Vectors of a solve and of its float64 references beside it: at most BiCG-STAB's 7 slots plus ρ and E, in
// double, three channels, twice, and the host's copies of B (a few per run).
double vector_bytes(size_t n);

}  // namespace radiosity::app
