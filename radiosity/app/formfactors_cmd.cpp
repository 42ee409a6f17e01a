// `bin/radiosity formfactors`: the hemicube once, into a form-factor file named for the mesh (report §3.6). Under
// mpirun (MPI_Init by main) every rank computes its block of rows, balanced by an estimate of each row's hemicube
// work, and the ranks write the one file together with MPI-IO (radiosity/dist/).
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/cli.hpp"
#include "common/memory.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/app/distributed.hpp"
#include "radiosity/dist/split.hpp"
#include "radiosity/formfactor/diagnostics.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/formfactor/hemicube.hpp"
#include "radiosity/solve/storage/ff_matrix_file.hpp"
#ifdef HAVE_MPI
#include "radiosity/dist/ff_mpi.hpp"
#endif

namespace radiosity::app {

void add_formfactors(CLI::App& app, FormFactorArgs& a) {
  CLI::App* cmd = app.add_subcommand(
      "formfactors",
      "compute the form factors of a scene by the hemicube into a file; under mpirun -np P every rank computes a "
      "block of rows (balanced by estimated work) and the ranks write the one file together (MPI-IO): the same bytes "
      "as one process writes, so any number of ranks, or the serial program, reads it");
  add_scene_options(cmd, a);
  add_memory_option(cmd, a);
  cmd->add_option("-o,--out", a.out, "form-factor file to write")->required();
  cmd->add_option("--hemicube", a.hemicube.resolution, "hemicube resolution R (top face R x R)")
      ->capture_default_str();
  cmd->add_option("--weights", a.weights, "exact (Cohen-Greenberg delta form factors) or rrv2007 (RRV's cos*cos)")
      ->check(CLI::IsMember({"exact", "rrv2007"}))->capture_default_str();
  cmd->add_option("--threshold", a.hemicube.threshold, "store form factors <= T as 0 (RRV's threshold)")
      ->check(hpcgi::fraction_below_one())->capture_default_str();
  cmd->add_option("--split", a.split,
                  "under mpirun: rows in blocks of equal estimated hemicube work (work) or of equal count (rows, to "
                  "compare)")
      ->check(CLI::IsMember({"work", "rows"}))->capture_default_str();
  cmd->add_option("--storage", a.storage,
                  "the file's storage: dense (version 1, what every reader takes) | csr | compressed (version 2: "
                  "only the non-zero F_ij, read by solve on serial and openmp; one process)")
      ->check(CLI::IsMember({"dense", "csr", "compressed"}))->capture_default_str();
  cmd->add_option("--ff-precision", a.ff_precision,
                  "the values of a csr or compressed file: float32 | float16 (scaled by a power of two) | bfloat16")
      ->check(CLI::IsMember({"float32", "float16", "bfloat16"}))->capture_default_str();
}

namespace {

// The smallest and largest row sum of a block of rows, across the ranks.
struct RowSums {
  double min = HUGE_VAL, max = -HUGE_VAL;
};
RowSums row_sums(const FormFactorRows& rows) {
  RowSums s;
  for (size_t k = 0; k < rows.rows(); ++k) {
    double sum = 0;
    for (size_t j = 0; j < rows.n; ++j) sum += rows.values[k * rows.n + j];
    s.min = std::min(s.min, sum);
    s.max = std::max(s.max, sum);
  }
  s.min = hpcgi::comm::min(s.min);
  s.max = hpcgi::comm::max(s.max);
  return s;
}

// A csr or compressed file (version 2) of one process's rows: every row kept (the file belongs to the geometry),
// the copy's memory checked before it is built.
void save_sparse_form_factors(const std::string& path, const Mesh& m, const FormFactorRows& rows,
                              const std::string& storage, const std::string& precision) {
  const size_t n = rows.n;
  const std::vector<Rgb> every_row(n, Rgb{1, 1, 1});
  FFMatrixOptions opt;
  opt.storage = parse_ff_storage(storage);
  opt.values = parse_ff_values(precision);
  const size_t kept = count_kept(rows.values.data(), n, every_row, 0);
  const size_t bridges = opt.storage == FFStorage::compressed ? count_bridges(rows.values.data(), n, every_row, 0) : 0;
  hpcgi::require_host_memory("the " + storage + " " + precision + " copy of the form factors of " +
                                 std::to_string(n) + " patches",
                             ff_storage_bytes(opt.storage, opt.values, n, kept, bridges));
  save_form_factor_matrix(path, m, rows.params, FormFactorMatrix(rows.values.data(), n, every_row, opt));
}

}  // namespace

int run_formfactors(const FormFactorArgs& a) {
  hpcgi::Timer total;
  HemicubeParams hp = a.hemicube;
  double limit = 0;
  hpcgi::comm::agreed([&] {  // every rank checks alike, rank 0 reports
    hp.weights = parse_hemicube_weights(a.weights);
    validate(hp);
    limit = a.memory_limit();
    check_files(a, {{a.out, "-o"}}, {});
    if (a.storage == "dense" && a.ff_precision != "float32")
      throw hpcgi::UsageError("--ff-precision " + a.ff_precision + " is for a csr or compressed file (a dense file "
                              "holds float32; solve --ff-precision stores it in 16 bits when it loads it)");
    if (a.storage != "dense" && hpcgi::comm::size() > 1)
      throw hpcgi::UsageError("a " + a.storage + " file is written by one process (the ranks write dense rows at "
                              "fixed offsets): run formfactors without mpirun, or --storage dense");
  });
  const bool dist = hpcgi::comm::active();
  const int ranks = hpcgi::comm::size(), rank = hpcgi::comm::rank();
  const bool root = hpcgi::comm::root();
  double load_s = 0;
  const Mesh m = hpcgi::comm::agreed([&] {
    Mesh mesh = load_scene(a, &load_s);
    require_rows_for_ranks(mesh.size(), ranks);
    return mesh;
  });
  const size_t n = m.size();
  const double n2 = double(n) * double(n);
  const int threads = omp_get_max_threads();

  // The split: rows in blocks of equal estimated hemicube work, the same on every rank (each computes the same
  // estimate). The work split gives more rows, so more memory, to the ranks whose rows are cheap; when that alone
  // would break --max-memory-per-rank and blocks of equal count would not, the blocks of equal count are taken.
  hpcgi::Timer t;
  const bool estimate = a.split == "work" && (dist || limit > 0);  // a serial run estimates only for its advice
  const std::vector<uint64_t> work = estimate ? hemicube_row_work(m, hp) : std::vector<uint64_t>();
  const std::vector<uint64_t> ones(n, 1);
  const double split_s = t.seconds();
  auto needs_of = [&](const std::vector<size_t>& b) {
    std::vector<RankNeed> v;
    for (size_t r = 0; r + 1 < b.size(); ++r) {
      const size_t rows = b[r + 1] - b[r];
      v.push_back({rows, 4.0 * double(rows) * double(n),
                   hemicube_memory_bytes(n, rows, hp.resolution, threads) - 4.0 * double(rows) * double(n) +
                       double(sizeof(Patch)) * double(n)});
    }
    return v;
  };
  auto largest = [](const std::vector<RankNeed>& v) {
    double m = 0;
    for (const RankNeed& x : v) m = std::max(m, x.total());
    return m;
  };
  bool by_count = !estimate;  // of the split this run takes (bounds below)
  auto split = [&](int p, bool* counted = nullptr) {
    std::vector<size_t> b = dist::split_by_work(estimate ? work : ones, p);
    bool count = !estimate;
    if (estimate && limit > 0 && largest(needs_of(b)) > limit) {
      std::vector<size_t> even = dist::split_by_work(ones, p);
      if (largest(needs_of(even)) <= limit) {
        b = std::move(even);
        count = true;
      }
    }
    if (counted) *counted = count;
    return b;
  };
  const NeedsAt needs = [&](int p) { return needs_of(split(p)); };
  const std::vector<size_t> bounds = split(ranks, &by_count);
  const dist::RowBlock block = dist::block_of(bounds, rank);
  const std::string patches = std::to_string(n) + " patches";
  require_memory_per_rank(limit, needs, ranks, "the form factors of " + patches,
                          "bin/radiosity formfactors ... (the file is the same)");
  const RankNeed mine = needs(ranks)[size_t(rank)];
  hpcgi::comm::agreed([&] {
    hpcgi::require_host_memory(dist ? "rank " + std::to_string(rank) + "'s " + std::to_string(block.rows()) +
                                          " rows of the form factors of " + patches
                                    : "the form factors of " + patches,
                               mine.total());
  });

  t.reset();
  FormFactorRows rows = compute_form_factor_rows(m, hp, block.begin, block.end,
                                                 a.quiet || ranks > 1 ? HemicubeProgress{} : stderr_progress());
  const double compute_s = t.seconds();
  const std::vector<double> rank_compute_s = hpcgi::comm::gather(compute_s);
  const double slowest_s = *std::max_element(rank_compute_s.begin(), rank_compute_s.end());

  // Diagnostics: the row sums from every rank's rows; reciprocity (A_i F_ij = A_j F_ji) needs F_ji, which lies in
  // another rank's rows for most pairs, so it is computed where one process holds all of F only.
  t.reset();
  FormFactorDiagnostics d;
  bool reciprocity = false;
  if (ranks == 1) {
    FormFactors whole{n, std::move(rows.values), rows.params};
    d = diagnose_form_factors(m, whole);
    rows.values = std::move(whole.values);
    reciprocity = true;
  } else {
    const RowSums s = row_sums(rows);
    d.min_row_sum = s.min;
    d.max_row_sum = s.max;
  }
  uint64_t nonzero = 0;
  for (float v : rows.values) nonzero += v != 0.0f;
  hpcgi::comm::sum(&nonzero, 1);
  const double diag_s = t.seconds();

  t.reset();
  double rank_io_s = 0, chain_s = 0, checksum_s = 0;
  if (dist) {
#ifdef HAVE_MPI
    const dist::FileStats st = dist::save_form_factor_rows(a.out, m, rows);
    rank_io_s = st.io_s;
    chain_s = st.chain_s;
    checksum_s = st.checksum_s;
#endif
  } else if (a.storage == "dense") {
    FormFactors whole{n, std::move(rows.values), rows.params};
    save_form_factors(a.out, m, whole);
  } else {
    save_sparse_form_factors(a.out, m, rows, a.storage, a.ff_precision);
  }
  const double save_s = t.seconds();

  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "formfactors"}, {"scene", a.scene},          {"divide", a.load.divide},
                   {"patches", m.size()},      {"hemicube", hp.resolution}, {"weights", a.weights},
                   {"threshold", hp.threshold}, {"threads", threads}, {"storage", a.storage},
                   {"ff_precision", a.ff_precision}};
  if (dist) {
    rec["params"]["backend"] = "mpi";
    rec["params"]["ranks"] = ranks;
    rec["params"]["split"] = a.split;
    rec["params"]["split_taken"] = by_count ? "rows" : "work";
  }
  rec["result"] = {{"min_row_sum", d.min_row_sum},
                   {"max_row_sum", d.max_row_sum},
                   {"max_reciprocity_error", reciprocity ? nlohmann::json(d.max_reciprocity_error) : nlohmann::json()},
                   {"mean_reciprocity_error",
                    reciprocity ? nlohmann::json(d.mean_reciprocity_error) : nlohmann::json()},
                   {"reciprocity_pairs", reciprocity ? nlohmann::json(d.pairs_compared) : nlohmann::json()},
                   {"nonzero_fraction", static_cast<double>(nonzero) / n2},
                   {"mesh_hash", mesh_hash(m)},
                   {"file", a.out}};
  rec["times_s"] = {{"load", load_s},
                    {"hemicube", slowest_s},
                    {"diagnostics", diag_s},
                    {"save", save_s},
                    {"total", total.seconds()}};
  rec["perf"] = {{"patches_per_s", double(n) / slowest_s}, {"peak_rss_bytes", peak_rss_bytes()}};
  if (dist) {
    nlohmann::json mpi = mpi_section(needs(ranks), limit);  // collective
    // The estimate of every rank's hemicube seconds on one core, whichever split was taken.
    const std::vector<uint64_t> cost = estimate ? work : hemicube_row_work(m, hp);
    std::vector<double> est;
    for (int r = 0; r < ranks; ++r) {
      double w = 0;
      for (size_t i = bounds[r]; i < bounds[r + 1]; ++i) w += double(cost[i]);
      est.push_back(w * 1e-9);
    }
    mpi["split"] = !by_count      ? "rows in blocks of equal estimated hemicube work (hemicube_row_work)"
                   : estimate     ? "rows in blocks of equal count (the work split would exceed --max-memory-per-rank)"
                                  : "rows in blocks of equal count";
    mpi["split_s"] = split_s;
    mpi["rank_estimated_s"] = est;
    mpi["rank_hemicube_s"] = rank_compute_s;
    mpi["rank_write_s"] = hpcgi::comm::gather(rank_io_s);
    mpi["rank_checksum_s"] = hpcgi::comm::gather(checksum_s);
    mpi["rank_chain_wait_s"] = hpcgi::comm::gather(chain_s);
    double mean = 0;
    for (double s : rank_compute_s) mean += s / ranks;
    mpi["hemicube_imbalance"] = mean > 0 ? slowest_s / mean : 1.0;
    mpi["file"] = "one file, format v1, written by all ranks with MPI-IO";
    rec["mpi"] = mpi;
  }
  if (!root) return 0;
  rec["result"]["file_bytes"] = std::filesystem::file_size(a.out);
  if (!a.quiet) {
    std::printf("formfactors: %s, %zu patches (divide %g), hemicube R=%d %s weights, threshold %g, %d threads%s\n",
                a.scene.c_str(), m.size(), a.load.divide, hp.resolution, a.weights.c_str(), hp.threshold, threads,
                dist ? (", " + std::to_string(ranks) + " MPI ranks").c_str() : "");
    if (reciprocity)
      std::printf("  row sums %.4f .. %.4f; reciprocity error max %.3g, mean %.3g over %zu pairs; %.1f%% non-zero\n",
                  d.min_row_sum, d.max_row_sum, d.max_reciprocity_error, d.mean_reciprocity_error, d.pairs_compared,
                  100.0 * static_cast<double>(nonzero) / n2);
    else
      std::printf("  row sums %.4f .. %.4f; %.1f%% non-zero (reciprocity is checked on one rank only)\n",
                  d.min_row_sum, d.max_row_sum, 100.0 * static_cast<double>(nonzero) / n2);
    if (d.max_row_sum > kRowSumNote)
      std::printf("  note: a row of F sums to %.4f, more than %.2f: the hemicube is too coarse for this mesh (R=%d), "
                  "and radiosity gains energy it should lose; use a larger --hemicube\n", d.max_row_sum, kRowSumNote,
                  hp.resolution);
    if (dist) {
      std::printf("  ranks: rows");
      for (int r = 0; r < ranks; ++r) std::printf(" %zu", bounds[r + 1] - bounds[r]);
      std::printf("; hemicube s");
      for (double s : rank_compute_s) std::printf(" %.3f", s);
      std::printf("; F held MiB");
      for (int r = 0; r < ranks; ++r) std::printf(" %.1f", 4.0 * double(bounds[r + 1] - bounds[r]) * n / (1 << 20));
      std::printf("\n");
    }
    std::printf("  time: load %.3f s, hemicube %.3f s (%.1f patches/s), save %.3f s -> %s\n", load_s, slowest_s,
                double(n) / slowest_s, save_s, a.out.c_str());
  }
  hpcgi::record::emit(rec, a);
  return 0;
}

}  // namespace radiosity::app
