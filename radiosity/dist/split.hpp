// Row blocks for MPI ranks (as the Poisson solver splits its grid): rank r holds rows [bounds[r], bounds[r+1]),
// contiguous and in order, so that a rank's rows are one range of the form-factor file and its blocks of a vector
// are one piece of an MPI_Allgatherv. The blocks are balanced by an estimate of each row's work (a hemicube row costs
// more where more patches lie in front of it), or by count with equal work (a solver's rank holds its rows of F
// dense: equal counts balance the memory).
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

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

}  // namespace radiosity::dist
