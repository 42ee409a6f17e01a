#include "radiosity/app/distributed.hpp"

#include <sys/resource.h>

#include <algorithm>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"

namespace radiosity::app {
namespace {

const RankNeed& largest(const std::vector<RankNeed>& needs) {
  return *std::max_element(needs.begin(), needs.end(),
                           [](const RankNeed& x, const RankNeed& y) { return x.total() < y.total(); });
}

}  // namespace

void require_memory_per_rank(double limit, const NeedsAt& needs, int ranks, const std::string& what,
                             const std::string& how) {
  if (!(limit > 0)) return;
  const std::vector<RankNeed> now = needs(ranks);
  const RankNeed& worst = largest(now);
  if (worst.total() <= limit) return;
  const int r = int(&worst - now.data());
  std::string msg = "rank " + std::to_string(r) + " of " + std::to_string(ranks) + " would hold " +
                    hpcgi::format_bytes(worst.total()) + " for " + what + " (its " + std::to_string(worst.rows) +
                    " rows of the form factors " + hpcgi::format_bytes(worst.ff_bytes) + ", the rest " +
                    hpcgi::format_bytes(worst.other_bytes) + "), more than --max-memory-per-rank " +
                    hpcgi::format_bytes(limit) + "; ";
  int fits = 0;
  for (int p = ranks + 1; p <= 4096 && !fits; ++p)
    if (largest(needs(p)).total() <= limit) fits = p;
  if (fits)
    msg += "on " + std::to_string(fits) + " ranks each holds at most " +
           hpcgi::format_bytes(largest(needs(fits)).total()) + ": mpirun -np " + std::to_string(fits) + " " + how;
  else
    msg += "no number of ranks up to 4096 fits (what every rank holds whatever their number, the vectors and buffers, is " +
           hpcgi::format_bytes(worst.other_bytes) + ")";
  throw hpcgi::Agreed<hpcgi::UsageError>(msg);
}

double peak_rss_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1024.0 * double(u.ru_maxrss);  // kilobytes on Linux
}

nlohmann::json mpi_section(const std::vector<RankNeed>& needs, double limit) {
  nlohmann::json j;
  j["ranks"] = hpcgi::comm::size();
  j["library"] = hpcgi::comm::library();
  j["max_memory_per_rank"] = limit > 0 ? nlohmann::json(limit) : nlohmann::json();
  std::vector<double> rows, ff, need;
  for (const RankNeed& x : needs) {
    rows.push_back(double(x.rows));
    ff.push_back(x.ff_bytes);
    need.push_back(x.total());
  }
  j["rank_rows"] = rows;
  j["rank_ff_bytes"] = ff;
  j["rank_need_bytes"] = need;
  j["rank_peak_rss_bytes"] = hpcgi::comm::gather(peak_rss_bytes());  // collective
  return j;
}

}  // namespace radiosity::app
