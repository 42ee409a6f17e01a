// What `--storage auto` (the default) picks: of the storages the backend reads, the one whose product moves the
// fewest bytes of F per step (what Kernels::matrix_bytes reports): dense v·n per computed row, csr kept·(v + 4),
// compressed (kept + bridges)·(v + 2), plus 8·(n + 1) of row starts for these sparse ones, runs entries·v + 4·runs
// + 16·(n + 1) (v: the value's bytes).
// Everything else a step moves (the vectors, O(n)) is the same in every storage. A sparse storage is taken over
// dense only where it moves at most kSparseShare of dense's bytes: the sparse products read their bytes more slowly
// than dense's four-stream sweep (room3, 1 thread, this project's EPYC VM, min of 30 products in the same minute:
// dense float32 375 MB in 25.6 ms, 14.6 GB/s; runs float16 43 MB in 9.3 ms, 4.6 GB/s; compressed float16 70 MB in
// 9.4 ms, 7.4 GB/s), so a matrix with few zeros (a closed box: runs move 86% of dense's bytes) keeps dense. A tie
// keeps dense.
#pragma once
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/solve.hpp"

namespace radiosity {

struct StorageCounts {
  size_t n = 0;            // patches
  size_t kept = 0;         // F_ij kept in the rows that are needed (count_kept)
  size_t bridges = 0;      // compressed's bridges (count_bridges)
  size_t rows_needed = 0;  // rows a dense product computes (patches whose reflectivity is not 0)
  RunCounts runs;          // the runs storage's runs and values (count_runs); runs.entries >= kept once counted
};

// The bytes of F one product reads in this storage (runs: throws std::invalid_argument when c.runs is not counted).
double step_bytes(FFStorage storage, FFValues values, const StorageCounts& c);

// The storages a backend reads with these values (reads_storage): every one for serial, openmp and mpi; csr and
// compressed, and dense for float32 values, on the GPU backends; else dense. Never empty for float32 values.
std::vector<FFStorage> readable_storages(const SolveBackend& b, FFValues values = FFValues::float32);

inline constexpr double kSparseShare = 0.5;

// The storage of `readable` (not empty) with the fewest step_bytes, a sparse one only below kSparseShare of dense's
// where dense is readable (dense on a tie; else the first of the fewest).
FFStorage fewest_bytes_storage(const std::vector<FFStorage>& readable, FFValues values, const StorageCounts& c);

// The counts of an n×n dense float32 F: kept values, rows needed, and the bridges and runs where `readable` holds
// compressed and runs (else 0: not counted, so not to be chosen). F may hold only rows [row_begin, row_end) (an MPI
// rank's block, F pointing at its first row): those are counted, and a multi-process solve sums its ranks' counts
// (solve_load.cpp).
StorageCounts count_storages(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                             const std::vector<FFStorage>& readable, size_t row_begin = 0,
                             size_t row_end = SIZE_MAX);

// The storage a run's form factors take and what they keep.
struct StorageChoice {
  FFStorage storage = FFStorage::dense;
  size_t kept = 0;       // values kept (summed over MPI ranks)
  bool dropped = false;  // the threshold drops some of the file's values
  size_t bridges = 0;    // compressed's bridges
  RunCounts runs;        // the runs storage's runs and values
};

// The storage of a solve on backend b of dense float32 F (rows [row_begin, row_end), F pointing at the first; an MPI
// rank's block, the counts summed over the ranks): `asked` where given, else fewest_bytes_storage of what b reads.
StorageChoice choose_storage(const float* F, size_t n, const std::vector<Rgb>& reflectivity, double threshold,
                             const SolveBackend& b, FFValues values, std::optional<FFStorage> asked, size_t row_begin,
                             size_t row_end);
// A sparse file's matrix as stored: its own storage and counts.
StorageChoice stored_storage(const FormFactorMatrix& stored);

// Each row's entries in opt's storage at i (its kept values, and compressed's bridges; runs: its stored values) and
// its runs (runs storage) at n + i, counted in rows [row_begin, row_end) of dense F (F pointing at the first) and
// summed over the MPI ranks.
std::vector<uint64_t> row_entries(const float* F, size_t n, const std::vector<Rgb>& reflectivity,
                                  const FFMatrixOptions& opt, size_t row_begin, size_t row_end);
// Each row's cost in the product from row_entries: its entries, kRunCost a run and kRowCost (ff_matrix.hpp); the
// work an MPI rank's rows are balanced by (dist::split_by_work).
std::vector<uint64_t> row_costs(const std::vector<uint64_t>& entries);

}  // namespace radiosity
