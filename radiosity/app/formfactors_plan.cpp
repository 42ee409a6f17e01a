// formfactors' plan (the request's checks, once) and split (each rank's rows and their memory).
#include <omp.h>

#include <algorithm>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/timer.hpp"
#include "radiosity/app/formfactors_phases.hpp"
#include "radiosity/dist/split.hpp"
#include "radiosity/formfactor/hemicube.hpp"

namespace radiosity::app {

FormFactorPlan plan_formfactors(const FormFactorArgs& a) {
  FormFactorPlan p;
  p.hemicube = a.hemicube;
  hpcgi::comm::agreed([&] {  // every rank checks alike, rank 0 reports
    p.hemicube.weights = parse_hemicube_weights(a.weights);
    validate(p.hemicube);
    p.limit = a.memory_limit();
    check_files(a, {{a.out, "-o"}}, {});
    if (a.storage == "dense" && a.ff_precision != "float32")
      throw hpcgi::UsageError("--ff-precision " + a.ff_precision + " is for a csr or compressed file (a dense file "
                              "holds float32; solve --ff-precision stores it in 16 bits when it loads it)");
    if (a.storage != "dense" && hpcgi::comm::size() > 1)
      throw hpcgi::UsageError("a " + a.storage + " file is written by one process (the ranks write dense rows at "
                              "fixed offsets): run formfactors without mpirun, or --storage dense");
  });
  return p;
}

std::vector<RankNeed> FormFactorSplit::needs(const std::vector<size_t>& b) const {
  std::vector<RankNeed> v;
  for (size_t r = 0; r + 1 < b.size(); ++r) {
    const size_t rows = b[r + 1] - b[r];
    const double ff = 4.0 * double(rows) * double(n);
    v.push_back({rows, ff, hemicube_memory_bytes(n, rows, resolution, threads) - ff + double(sizeof(Patch)) * double(n)});
  }
  return v;
}

namespace {
double largest(const std::vector<RankNeed>& v) {
  double m = 0;
  for (const RankNeed& x : v) m = std::max(m, x.total());
  return m;
}
}  // namespace

// The work split gives more rows, so more memory, to the ranks whose rows are cheap; when that alone would break
// --max-memory-per-rank and blocks of equal count would not, the blocks of equal count are taken.
std::vector<size_t> FormFactorSplit::bounds_for(int ranks, bool* counted) const {
  const std::vector<uint64_t> ones(n, 1);
  std::vector<size_t> b = dist::split_by_work(estimate ? work : ones, ranks);
  bool count = !estimate;
  if (estimate && limit > 0 && largest(needs(b)) > limit) {
    std::vector<size_t> even = dist::split_by_work(ones, ranks);
    if (largest(needs(even)) <= limit) {
      b = std::move(even);
      count = true;
    }
  }
  if (counted) *counted = count;
  return b;
}

FormFactorSplit split_formfactors(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan) {
  const int ranks = hpcgi::comm::size(), rank = hpcgi::comm::rank();
  const bool dist = hpcgi::comm::active();
  FormFactorSplit s;
  s.n = m.size();
  s.resolution = plan.hemicube.resolution;
  s.threads = omp_get_max_threads();
  s.limit = plan.limit;
  // The same estimate on every rank; a serial run estimates only for its advice on --max-memory-per-rank.
  hpcgi::Timer t;
  s.estimate = a.split == "work" && (dist || plan.limit > 0);
  if (s.estimate) s.work = hemicube_row_work(m, plan.hemicube);
  s.split_s = t.seconds();
  s.bounds = s.bounds_for(ranks, &s.by_count);
  const std::string patches = std::to_string(s.n) + " patches";
  require_memory_per_rank(plan.limit, [&s](int p) { return s.needs_at(p); }, ranks, "the form factors of " + patches,
                          "bin/radiosity formfactors ... (the file is the same)");
  const RankNeed mine = s.needs(s.bounds)[size_t(rank)];
  hpcgi::comm::agreed([&] {
    hpcgi::require_host_memory(dist ? "rank " + std::to_string(rank) + "'s " + std::to_string(mine.rows) +
                                          " rows of the form factors of " + patches
                                    : "the form factors of " + patches,
                               mine.total());
  });
  return s;
}

}  // namespace radiosity::app
