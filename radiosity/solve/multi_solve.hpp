// The driver's entry points for k right-hand sides on one F and ρ (the light basis: one per light): solve_multi runs
// the multi-right-hand-side method (methods/multi_rhs.hpp) on the k-product of cfg.backend (kernels.hpp's
// MultiKernels), and bench_multi_product times that product (relight --bench-rhs). Backends with a k-product:
// serial, openmp (the host kernels) and mpi (its row split, under mpirun); the others (the GPU backends, original)
// are refused with hpcgi::UsageError before anything is built.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/config/config.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

// Whether backend `name` has a k-right-hand-side product; the names of those that do ("serial, openmp, mpi").
bool has_multi_rhs(const std::string& name);
std::string multi_rhs_backends();

// The OpenMP threads a CPU backend runs for --threads `requested` (0: the OpenMP default).
int solver_threads(int requested);

struct MultiSolveResult {
  std::vector<std::vector<Rgb>> B;  // per right-hand side, n entries
  long iterations = 0;              // Jacobi steps before the answer
  SolveStatus status = SolveStatus::max_iter;  // converged | max_iter | nonfinite
  std::string detail;
  double max_residual = 0;          // over right-hand sides and channels: ‖E_q - A B_q‖ / ‖E_q‖ (1 where E_q,c = 0)
  long matrix_passes = 0;
  int threads = 1;
  double matrix_bytes = 0;          // what one k-product reads
  double setup_s = 0, solve_s = 0;
};

// Solves (I - diag(ρ) F) B_q = E_q for every q, from B_q = E_q, by cfg.method jacobi in cfg.precision on backend
// cfg.backend, until cfg.tol (at most cfg.max_iter steps). sys gives F and ρ (its emission is not read). Throws
// hpcgi::UsageError for a backend without a k-product, a bad configuration or system; numerical failure is the
// status. Under backend mpi it is collective.
MultiSolveResult solve_multi(const System& sys, const std::vector<std::vector<Rgb>>& E, const SolveConfig& cfg);

// relight --bench-rhs: the k-product of cfg.backend (cfg.precision) on X (k vectors; E_q the system's emission)
// `passes` times after one untimed warm-up, in turns with the product of X[0] alone (k = 1), then the backend's
// one-right-hand-side product (Kernels::matvec, AOS) on x = e + 0.5, as many times.
struct MultiBench {
  std::vector<double> product_ms, k1_ms, single_ms;
  double matrix_bytes = 0;  // what the k-product reads
  int threads = 1;
  std::vector<std::pair<std::string, double>> facts;  // the backend's (MultiKernels::facts)
};
MultiBench bench_multi_product(const System& sys, const std::vector<std::vector<Rgb>>& X, const SolveConfig& cfg,
                               long passes);

}  // namespace radiosity
