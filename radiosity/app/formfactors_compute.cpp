// formfactors' compute (this rank's rows by the hemicube, and their diagnostics) and write (the file at -o).
#include <algorithm>
#include <cmath>

#include "common/comm.hpp"
#include "common/memory.hpp"
#include "common/timer.hpp"
#include "radiosity/app/formfactors_phases.hpp"
#include "radiosity/dist/split.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/hemicube.hpp"
#include "radiosity/formfactor/file/sparse.hpp"
#ifdef HAVE_MPI
#include "radiosity/formfactor/file/mpi_rows.hpp"
#endif

namespace radiosity::app {
namespace {

// The smallest and largest row sum of a block of rows, across the ranks.
void row_sums(const FormFactors& rows, FormFactorDiagnostics& d) {
  d.min_row_sum = HUGE_VAL, d.max_row_sum = -HUGE_VAL;
  for (size_t k = 0; k < rows.rows(); ++k) {
    double sum = 0;
    for (size_t j = 0; j < rows.n; ++j) sum += rows.values[k * rows.n + j];
    d.min_row_sum = std::min(d.min_row_sum, sum);
    d.max_row_sum = std::max(d.max_row_sum, sum);
  }
  d.min_row_sum = hpcgi::comm::min(d.min_row_sum);
  d.max_row_sum = hpcgi::comm::max(d.max_row_sum);
}

// A csr, compressed or runs file (version 2) of one process's rows: every row kept (the file belongs to the geometry),
// the copy's memory checked before it is built.
void save_sparse_form_factors(const std::string& path, const Mesh& m, const FormFactors& rows,
                              const std::string& storage, const std::string& precision) {
  const size_t n = rows.n;
  const std::vector<Rgb> every_row(n, Rgb{1, 1, 1});
  FFMatrixOptions opt;
  opt.storage = parse_ff_storage(storage);
  opt.values = parse_ff_values(precision);
  const size_t kept = count_kept(rows.values.data(), n, every_row, 0);
  const size_t bridges = opt.storage == FFStorage::compressed ? count_bridges(rows.values.data(), n, every_row, 0) : 0;
  const RunCounts runs = opt.storage == FFStorage::runs ? count_runs(rows.values.data(), n, every_row, opt) : RunCounts{};
  hpcgi::require_host_memory("the " + storage + " " + precision + " copy of the form factors of " +
                                 std::to_string(n) + " patches",
                             ff_storage_bytes(opt.storage, opt.values, n, kept, bridges, runs));
  save_form_factor_matrix(path, m, rows.params, FormFactorMatrix(rows.values.data(), n, every_row, opt));
}

}  // namespace

ComputedRows compute_formfactors(const FormFactorArgs& a, const Mesh& m, const FormFactorPlan& plan,
                                 const FormFactorSplit& split) {
  const int ranks = hpcgi::comm::size();
  const dist::RowBlock block = dist::block_of(split.bounds, hpcgi::comm::rank());
  ComputedRows c;
  hpcgi::Timer t;
  c.rows = compute_form_factor_rows(m, plan.hemicube, block.begin, block.end,
                                    a.quiet || ranks > 1 ? HemicubeProgress{} : stderr_progress());
  c.rank_compute_s = hpcgi::comm::gather(t.seconds());
  c.slowest_s = *std::max_element(c.rank_compute_s.begin(), c.rank_compute_s.end());

  // Reciprocity (A_i F_ij = A_j F_ji) needs F_ji, which lies in another rank's rows for most pairs, so it is
  // computed where one process holds all of F only.
  t.reset();
  if (ranks == 1) {
    c.d = diagnose_form_factors(m, c.rows);
    c.reciprocity = true;
  } else {
    row_sums(c.rows, c.d);
  }
  for (float v : c.rows.values) c.nonzero += v != 0.0f;
  hpcgi::comm::sum(&c.nonzero, 1);
  c.diag_s = t.seconds();
  return c;
}

WriteStats write_formfactors(const FormFactorArgs& a, const Mesh& m, const FormFactors& rows) {
  WriteStats w;
  hpcgi::Timer t;
  if (hpcgi::comm::active()) {
#ifdef HAVE_MPI
    const dist::FileStats st = dist::save_form_factor_rows(a.out, m, rows);
    w.rank_io_s = st.io_s;
    w.chain_s = st.chain_s;
    w.checksum_s = st.checksum_s;
#endif
  } else if (a.storage == "dense") {
    save_form_factors(a.out, m, rows);
  } else {
    save_sparse_form_factors(a.out, m, rows, a.storage, a.ff_precision);
  }
  w.save_s = t.seconds();
  return w;
}

}  // namespace radiosity::app
