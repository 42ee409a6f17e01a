// formfactors' report: the run record and the printed summary.
#include <cstdio>

#include "common/comm.hpp"
#include "common/record.hpp"
#include "radiosity/app/formfactors_phases.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/hemicube.hpp"

namespace radiosity::app {
namespace {

// The "mpi" section (collective): the split taken, every rank's estimated and measured seconds, the balance.
nlohmann::json mpi_of(const Mesh& m, const FormFactorPlan& plan, const FormFactorSplit& s, const ComputedRows& c,
                      const WriteStats& w) {
  const int ranks = hpcgi::comm::size();
  nlohmann::json mpi = mpi_section(s.needs(s.bounds), plan.limit);
  // The estimate of every rank's hemicube seconds on one core, whichever split was taken.
  const std::vector<uint64_t> cost = s.estimate ? s.work : hemicube_row_work(m, plan.hemicube);
  std::vector<double> est;
  for (int r = 0; r < ranks; ++r) {
    double work = 0;
    for (size_t i = s.bounds[r]; i < s.bounds[r + 1]; ++i) work += double(cost[i]);
    est.push_back(work * 1e-9);
  }
  mpi["split"] = !s.by_count   ? "rows in blocks of equal estimated hemicube work (hemicube_row_work)"
                 : s.estimate ? "rows in blocks of equal count (the work split would exceed --max-memory-per-rank)"
                              : "rows in blocks of equal count";
  mpi["split_s"] = s.split_s;
  mpi["rank_estimated_s"] = est;
  mpi["rank_hemicube_s"] = c.rank_compute_s;
  mpi["rank_write_s"] = hpcgi::comm::gather(w.rank_io_s);
  mpi["rank_checksum_s"] = hpcgi::comm::gather(w.checksum_s);
  mpi["rank_chain_wait_s"] = hpcgi::comm::gather(w.chain_s);
  double mean = 0;
  for (double x : c.rank_compute_s) mean += x / ranks;
  mpi["hemicube_imbalance"] = mean > 0 ? c.slowest_s / mean : 1.0;
  mpi["file"] = "one file, format v1, written by all ranks with MPI-IO";
  return mpi;
}

}  // namespace

nlohmann::json formfactors_record(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan,
                                  const FormFactorSplit& split, const ComputedRows& c, const WriteStats& w,
                                  const FormFactorTimes& times) {
  const bool dist = hpcgi::comm::active();
  const HemicubeParams& hp = plan.hemicube;
  const double n = double(m.size()), n2 = n * n;
  const FormFactorDiagnostics& d = c.d;
  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "formfactors"}, {"scene", a.scene},          {"divide", a.load.divide},
                   {"patches", m.size()},      {"hemicube", hp.resolution}, {"weights", a.weights},
                   {"threshold", hp.threshold}, {"threads", split.threads}, {"storage", a.storage},
                   {"ff_precision", a.ff_precision}};
  if (dist) {
    rec["params"]["backend"] = "mpi";
    rec["params"]["ranks"] = hpcgi::comm::size();
    rec["params"]["split"] = a.split;
    rec["params"]["split_taken"] = split.by_count ? "rows" : "work";
  }
  auto if_reciprocity = [&](auto x) { return c.reciprocity ? nlohmann::json(x) : nlohmann::json(); };
  rec["result"] = {{"min_row_sum", d.min_row_sum},
                   {"max_row_sum", d.max_row_sum},
                   {"max_reciprocity_error", if_reciprocity(d.max_reciprocity_error)},
                   {"mean_reciprocity_error", if_reciprocity(d.mean_reciprocity_error)},
                   {"reciprocity_pairs", if_reciprocity(d.pairs_compared)},
                   {"nonzero_fraction", static_cast<double>(c.nonzero) / n2},
                   {"mesh_hash", mesh_hash(m)},
                   {"file", a.out}};
  rec["times_s"] = {{"load", times.load_s},
                    {"hemicube", c.slowest_s},
                    {"diagnostics", c.diag_s},
                    {"save", w.save_s},
                    {"total", times.total_s}};
  rec["perf"] = {{"patches_per_s", n / c.slowest_s}, {"peak_rss_bytes", peak_rss_bytes()}};
  if (dist) rec["mpi"].update(mpi_of(m, plan, split, c, w));  // beside the hosts record::make put there
  return rec;
}

void print_formfactors_summary(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan,
                               const FormFactorSplit& split, const ComputedRows& c, const WriteStats& w,
                               double load_s) {
  const bool dist = hpcgi::comm::active();
  const int ranks = hpcgi::comm::size();
  const HemicubeParams& hp = plan.hemicube;
  const FormFactorDiagnostics& d = c.d;
  const size_t n = m.size();
  const double nonzero_pct = 100.0 * static_cast<double>(c.nonzero) / (double(n) * double(n));
  std::printf("formfactors: %s, %zu patches (divide %g), hemicube R=%d %s weights, threshold %g, %d threads%s\n",
              a.scene.c_str(), n, a.load.divide, hp.resolution, a.weights.c_str(), hp.threshold, split.threads,
              dist ? (", " + std::to_string(ranks) + " MPI ranks").c_str() : "");
  if (c.reciprocity)
    std::printf("  row sums %.4f .. %.4f; reciprocity error max %.3g, mean %.3g over %zu pairs; %.1f%% non-zero\n",
                d.min_row_sum, d.max_row_sum, d.max_reciprocity_error, d.mean_reciprocity_error, d.pairs_compared,
                nonzero_pct);
  else
    std::printf("  row sums %.4f .. %.4f; %.1f%% non-zero (reciprocity is checked on one rank only)\n",
                d.min_row_sum, d.max_row_sum, nonzero_pct);
  if (d.max_row_sum > kRowSumNote)
    std::printf("  note: a row of F sums to %.4f, more than %.2f: the hemicube is too coarse for this mesh (R=%d), "
                "and radiosity gains energy it should lose; use a larger --hemicube\n", d.max_row_sum, kRowSumNote,
                hp.resolution);
  if (dist) {
    const std::vector<size_t>& b = split.bounds;
    std::printf("  ranks: rows");
    for (int r = 0; r < ranks; ++r) std::printf(" %zu", b[r + 1] - b[r]);
    std::printf("; hemicube s");
    for (double s : c.rank_compute_s) std::printf(" %.3f", s);
    std::printf("; F held MiB");
    for (int r = 0; r < ranks; ++r) std::printf(" %.1f", 4.0 * double(b[r + 1] - b[r]) * n / (1 << 20));
    std::printf("\n");
  }
  std::printf("  time: load %.3f s, hemicube %.3f s (%.1f patches/s), save %.3f s -> %s\n", load_s, c.slowest_s,
              double(n) / c.slowest_s, w.save_s, a.out.c_str());
}

}  // namespace radiosity::app
