// What the subcommands share when they run on MPI ranks (formfactors under mpirun, solve --backend mpi): the memory
// each rank would hold, checked against --max-memory-per-rank before anything is allocated, and the record's
// per-rank section.
#pragma once
#include <nlohmann/json.hpp>

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace radiosity::app {

// What one rank of a run holds: its rows of F and everything else (vectors, buffers, the mesh).
struct RankNeed {
  size_t rows = 0;
  double ff_bytes = 0, other_bytes = 0;
  double total() const { return ff_bytes + other_bytes; }
};
// Every rank's need when the run is split over `ranks` ranks (the same list on every rank: the split depends only on
// the mesh and the rank count).
using NeedsAt = std::function<std::vector<RankNeed>(int ranks)>;

// --max-memory-per-rank (limit > 0): refuses, with the same Agreed<UsageError> on every rank, a run in which some
// rank would hold more than limit, naming that rank's share and the fewest ranks (up to 4096) whose largest share
// fits. `what` names the run ("the form factors of 6760 patches"), `how` the command to run it on more ranks.
void require_memory_per_rank(double limit, const NeedsAt& needs, int ranks, const std::string& what,
                             const std::string& how);

// The record's "mpi" section: ranks, the library, and per-rank lists (in rank order).
nlohmann::json mpi_section(const std::vector<RankNeed>& needs, double limit);

// Peak resident memory of this process (getrusage), in bytes.
double peak_rss_bytes();

}  // namespace radiosity::app
