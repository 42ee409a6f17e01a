#include "radiosity/app/reference.hpp"

#include <algorithm>
#include <cmath>

#include "common/timer.hpp"
#include "radiosity/solve/solve.hpp"

namespace radiosity::app {

ErrorReference converged_reference(const System& sys, const std::string& of) {
  hpcgi::Timer t;
  SolveConfig cfg;
  cfg.backend = holds_all_rows(sys) ? "openmp" : "mpi";  // an MPI rank's system is solved by the same ranks
  cfg.layout = Layout::aos;
  cfg.precision = Precision::double_;
  cfg.method = Method::bicgstab;
  cfg.tol = kReferenceTol;
  cfg.max_iter = 10000;
  SolveResult r = solve(sys, cfg);
  if (r.status != SolveStatus::converged) {
    SolveConfig jac = cfg;
    jac.method = Method::jacobi;
    jac.max_iter = 100000;
    SolveResult rj = solve(sys, jac);
    // Keep whichever got closer (Jacobi may stop divergent or nonfinite where BiCG-STAB at least got somewhere).
    const auto worst = [](const SolveResult& x) { return *std::max_element(x.rel_residual.begin(), x.rel_residual.end()); };
    if (rj.status == SolveStatus::converged || !(worst(r) <= worst(rj))) {
      r = std::move(rj);
      cfg = jac;
    }
  }
  ErrorReference ref;
  ref.of = of;
  ref.method = to_string(cfg.method);
  ref.iterations = r.iterations;
  ref.max_rel_residual = *std::max_element(r.rel_residual.begin(), r.rel_residual.end());
  ref.converged = r.status == SolveStatus::converged;
  ref.patches = sys.n;
  ref.B = std::move(r.B);
  ref.seconds = t.seconds();
  return ref;
}

double max_rel_diff(const std::vector<Rgb>& B, const std::vector<Rgb>& R) {
  double num = 0, den = 0;
  for (size_t i = 0; i < B.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double d = std::abs(B[i][c] - R[i][c]);
      if (std::isnan(d)) return d;
      num = std::max(num, d);
      den = std::max(den, std::abs(R[i][c]));
    }
  return den > 0 ? num / den : num;
}

}  // namespace radiosity::app
