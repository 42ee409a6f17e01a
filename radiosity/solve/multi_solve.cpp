// The driver of k right-hand sides (multi_solve.hpp): the backends with a k-product, the method run on it, the bench.
#include "radiosity/solve/multi_solve.hpp"

#include <omp.h>

#include <cmath>

#include "common/errors.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/methods/multi_rhs.hpp"
#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/physical.hpp"

namespace radiosity {
namespace {

// A backend's k-product and its one-right-hand-side kernels (for the bench's comparison), in both precisions.
struct MultiRow {
  const char* name;
  MultiFactory<float> multi_f;
  MultiFactory<double> multi_d;
  KernelFactory<float> single_f;
};
const std::vector<MultiRow>& multi_rows() {
  static const std::vector<MultiRow> rows = {
      {"serial", make_multi_serial<float>, make_multi_serial<double>, make_serial<float>},
      {"openmp", make_multi_openmp<float>, make_multi_openmp<double>, make_openmp<float>},
#ifdef HAVE_MPI
      {"mpi", make_multi_mpi<float>, make_multi_mpi<double>, make_mpi<float>},
#endif
  };
  return rows;
}

// The row of cfg.backend, after the driver's own checks of the request (check_config); throws for one without.
const MultiRow& require_multi(const SolveConfig& cfg) {
  check_config(cfg);
  for (const MultiRow& r : multi_rows())
    if (cfg.backend == r.name) return r;
  throw hpcgi::UsageError("backend '" + cfg.backend + "' has no k-right-hand-side product (" + multi_rhs_backends() +
                          " have)");
}

template <class T>
MultiSolveResult run_multi(MultiFactory<T> make, const System& sys, const std::vector<std::vector<Rgb>>& E,
                           const SolveConfig& cfg) {
  MultiSolveResult res;
  hpcgi::Timer t;
  auto k = make(sys, E, cfg, kMultiJacobiVectors);
  res.setup_s = t.seconds();
  std::vector<Rgb> scale(E.size());
  for (size_t q = 0; q < E.size(); ++q)
    for (int c = 0; c < 3; ++c) {
      double s = 0;
      for (const Rgb& v : E[q]) s += v[c] * v[c];
      scale[q][c] = s > 0 ? std::sqrt(s) : 1.0;
    }
  t.reset();
  const MultiMethodRun run = multi_jacobi<T>(*k, scale, cfg);
  res.solve_s = t.seconds();
  res.B.resize(E.size());
  for (size_t q = 0; q < E.size(); ++q) k->download(run.answer, q, res.B[q]);
  res.iterations = run.iterations;
  res.status = run.status;
  res.detail = run.detail;
  res.max_residual = run.worst;
  res.matrix_passes = run.matrix_passes;
  res.threads = k->threads();
  res.matrix_bytes = k->matrix_bytes();
  if (!failed(res.status)) {  // every right-hand side's answer gets the one physical check (physical.hpp)
    System one = sys;
    for (size_t q = 0; q < E.size(); ++q) {
      one.emission = E[q];
      const Rgb worst{run.worst, run.worst, run.worst};
      const PhysicalCheck c = check_physical(one, res.B[q], worst, cfg.tol, cfg.precision);
      if (c.status != SolveStatus::converged) {
        res.status = c.status;
        res.detail = "right-hand side " + std::to_string(q) + ": " + c.detail;
        break;
      }
    }
  }
  return res;
}

}  // namespace

bool has_multi_rhs(const std::string& name) {
  for (const MultiRow& r : multi_rows())
    if (name == r.name) return true;
  return false;
}

std::string multi_rhs_backends() {
  std::string s;
  for (const MultiRow& r : multi_rows()) s += (s.empty() ? "" : ", ") + std::string(r.name);
  return s;
}

int solver_threads(int requested) { return requested > 0 ? requested : omp_get_max_threads(); }

MultiSolveResult solve_multi(const System& sys, const std::vector<std::vector<Rgb>>& E, const SolveConfig& cfg) {
  check_system(sys);
  const MultiRow& row = require_multi(cfg);
  if (cfg.method != Method::jacobi)
    throw hpcgi::UsageError("k right-hand sides run jacobi, not " + to_string(cfg.method));
  if (E.empty()) throw hpcgi::UsageError("k right-hand sides: none given");
  for (const std::vector<Rgb>& e : E)
    if (e.size() != sys.n) throw hpcgi::UsageError("k right-hand sides: a right-hand side of another size than F");
  return cfg.precision == Precision::double_ ? run_multi<double>(row.multi_d, sys, E, cfg)
                                             : run_multi<float>(row.multi_f, sys, E, cfg);
}

MultiBench bench_multi_product(const System& sys, const std::vector<std::vector<Rgb>>& X, const SolveConfig& cfg,
                               long passes) {
  check_system(sys);
  const MultiRow& row = require_multi(cfg);
  const std::vector<std::vector<Rgb>> E(X.size(), sys.emission);
  auto k = row.multi_f(sys, E, cfg, 2);
  auto one = row.multi_f(sys, {sys.emission}, cfg, 2);
  for (size_t q = 0; q < X.size(); ++q) k->upload(0, q, X[q]), k->upload(1, q, X[q]);
  one->upload(0, 0, X[0]), one->upload(1, 0, X[0]);
  MultiBench b;
  // The k-product and the product with k = 1 in turns, pass by pass, so that their ratio compares passes that ran
  // under the same load; pass 0 warms the caches and the threads.
  for (long p = 0; p <= passes; ++p) {
    hpcgi::Timer t;
    k->matvec(1, 0, 0.0, 1.0, 1.0);
    const double tk = t.seconds() * 1e3;
    t.reset();
    one->matvec(1, 0, 0.0, 1.0, 1.0);
    if (p > 0) b.product_ms.push_back(tk), b.k1_ms.push_back(t.seconds() * 1e3);
  }
  // The same values through the one-right-hand-side product every solver runs, for comparison.
  SolveConfig single = cfg;
  single.layout = Layout::aos;
  single.channels = Channels::three;
  auto s = row.single_f(sys, single, 2);
  std::vector<Rgb> xh(sys.n);
  for (size_t i = 0; i < sys.n; ++i)
    for (int c = 0; c < 3; ++c) xh[i][c] = sys.emission[i][c] + 0.5;
  s->upload(0, xh);
  for (long p = 0; p <= passes; ++p) {
    hpcgi::Timer t;
    s->matvec(1, 0, 0.0, 1.0, 1.0);
    if (p > 0) b.single_ms.push_back(t.seconds() * 1e3);
  }
  b.matrix_bytes = k->matrix_bytes();
  b.threads = k->threads();
  b.facts = k->facts();
  return b;
}

}  // namespace radiosity
