// The phases of `bin/radiosity formfactors` (formfactors_cmd.cpp runs them in this order): plan (the request's
// checks, every rank alike), split (each rank's block of rows and its memory), compute (the hemicube and the
// diagnostics of the block), write (the file: MPI-IO, dense or sparse), report (the record and the printed summary).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "radiosity/app/commands.hpp"
#include "radiosity/app/distributed.hpp"
#include "radiosity/formfactor/diagnostics.hpp"

namespace radiosity::app {

// What the request asks, checked: the hemicube's parameters and --max-memory-per-rank's bytes (0: none).
struct FormFactorPlan {
  HemicubeParams hemicube;
  double limit = 0;
};
// Refuses (UsageError, agreed on every rank) bad hemicube parameters, files, --ff-precision on a dense file and a
// sparse file under mpirun.
FormFactorPlan plan_formfactors(const FormFactorArgs& a);

// The rows of each rank: blocks of equal estimated hemicube work, or of equal count (--split rows, a serial run, or
// when the work split alone would break --max-memory-per-rank and equal counts would not).
struct FormFactorSplit {
  size_t n = 0;
  int resolution = 0, threads = 1;
  bool estimate = false;       // the work was estimated (hemicube_row_work)
  bool by_count = true;        // the split taken is of equal count
  std::vector<uint64_t> work;  // the estimate, when made
  std::vector<size_t> bounds;  // rank r's rows: [bounds[r], bounds[r+1])
  double limit = 0, split_s = 0;
  std::vector<RankNeed> needs(const std::vector<size_t>& bounds) const;  // each rank's bytes under those bounds
  std::vector<size_t> bounds_for(int ranks, bool* by_count = nullptr) const;  // the split of `ranks` ranks
  std::vector<RankNeed> needs_at(int ranks) const { return needs(bounds_for(ranks)); }
};
// The split for this run's ranks, with the memory of every rank checked (refused alike on every rank).
FormFactorSplit split_formfactors(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan);

// This rank's rows and their diagnostics: row sums from every rank, reciprocity on one process only.
struct ComputedRows {
  FormFactors rows;  // this rank's rows (every row on one process)
  FormFactorDiagnostics d;
  bool reciprocity = false;
  uint64_t nonzero = 0;  // over all ranks
  std::vector<double> rank_compute_s;
  double slowest_s = 0, diag_s = 0;
};
ComputedRows compute_formfactors(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan,
                                 const FormFactorSplit& split);

// The file at -o, by every rank together (MPI-IO) or by one process (dense version 1, or csr/compressed version 2).
struct WriteStats {
  double save_s = 0, rank_io_s = 0, chain_s = 0, checksum_s = 0;
};
WriteStats write_formfactors(const FormFactorArgs& a, const Mesh& m, const FormFactors& rows);

// The record of the run (collective under MPI: its "mpi" section gathers from every rank); result.file_bytes is
// added by the root once the file is complete.
struct FormFactorTimes {
  double load_s = 0, total_s = 0;
};
nlohmann::json formfactors_record(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan,
                                  const FormFactorSplit& split, const ComputedRows& c, const WriteStats& w,
                                  const FormFactorTimes& times);
// The printed summary (rank 0, without --quiet).
void print_formfactors_summary(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan,
                               const FormFactorSplit& split, const ComputedRows& c, const WriteStats& w,
                               double load_s);

}  // namespace radiosity::app
