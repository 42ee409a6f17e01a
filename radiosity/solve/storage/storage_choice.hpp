// What `--storage auto` (the default) picks: of the storages the backend reads, the one whose product moves the
// fewest bytes of F per step (what Kernels::matrix_bytes reports): dense v·n per computed row, csr kept·(v + 4),
// compressed (kept + bridges)·(v + 2), plus 8·(n + 1) of row starts for both sparse ones (v: the value's bytes).
// Everything else a step moves (the vectors, O(n)) is the same in every storage. A tie keeps dense.
#pragma once
#include <cstddef>
#include <vector>

#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/solve.hpp"

namespace radiosity {

struct StorageCounts {
  size_t n = 0;            // patches
  size_t kept = 0;         // F_ij kept in the rows that are needed (count_kept)
  size_t bridges = 0;      // compressed's bridges (count_bridges)
  size_t rows_needed = 0;  // rows a dense product computes (patches whose reflectivity is not 0)
};

// The bytes of F one product reads in this storage.
double step_bytes(FFStorage storage, FFValues values, const StorageCounts& c);

// The storages a backend reads with these values (reads_storage): every one for serial, openmp and mpi; csr and
// compressed, and dense for float32 values, on the GPU backends; else dense. Never empty for float32 values.
std::vector<FFStorage> readable_storages(const SolveBackend& b, FFValues values = FFValues::float32);

// The storage of `readable` (not empty) with the fewest step_bytes (the first, dense where readable, on a tie).
FFStorage fewest_bytes_storage(const std::vector<FFStorage>& readable, FFValues values, const StorageCounts& c);

}  // namespace radiosity
