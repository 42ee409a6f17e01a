// Row blocks for MPI ranks (as the Poisson solver splits its grid): rank r holds rows [bounds[r], bounds[r+1]),
// contiguous and in order, so that a rank's rows are one range of the form-factor file and its blocks of a vector
// are one piece of an MPI_Allgatherv. The blocks are balanced by an estimate of each row's work, not by count: a
// hemicube row costs more where more patches lie in front of it, a solver's row nothing where its reflectivity is 0.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity::dist {

// parts + 1 bounds, bounds[0] = 0, bounds[parts] = work.size(), non-decreasing. Block r ends at the first row
// where the work of the rows before it reaches (r + 1)/parts of the total: each block's work is within one row's
// work of total/parts. A block may be empty (more parts than rows, or one row outweighing a share). Equal work
// everywhere gives blocks whose sizes differ by at most one row. Throws std::invalid_argument for parts < 1.
std::vector<size_t> split_by_work(const std::vector<uint64_t>& work, int parts);

struct RowBlock {
  size_t begin = 0, end = 0;
  size_t rows() const { return end - begin; }
};
inline RowBlock block_of(const std::vector<size_t>& bounds, int rank) {
  return {bounds[size_t(rank)], bounds[size_t(rank) + 1]};
}

// A solver's work per row: n (the row's n form factors, read every product) where the patch reflects, 1 where its
// reflectivity is 0 in every channel (the product skips the row: B_i = E_i).
std::vector<uint64_t> solve_row_work(const std::vector<Rgb>& reflectivity);

}  // namespace radiosity::dist
