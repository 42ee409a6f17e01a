#include "radiosity/app/solve_verify.hpp"

#include <algorithm>
#include <cstdio>

#include "common/comm.hpp"
#include "common/memory.hpp"
#include "common/timer.hpp"
#include "radiosity/formfactor/file/file.hpp"
#include "radiosity/solve/mesh_map.hpp"

namespace radiosity::app {

Verification verify(const System& sys, const SolveConfig& cfg, const SolveResult& res, const ErrorReference* converged) {
  hpcgi::Timer t;
  Verification v;
  std::vector<Rgb> R;
  if (cfg.steps > 0) {
    SolveConfig ref = cfg;
    ref.backend = holds_all_rows(sys) ? "openmp" : "mpi";  // an MPI rank's system: the same ranks check it
    ref.layout = Layout::aos;
    ref.precision = Precision::double_;
    ref.channels = Channels::three;
    ref.ff_threshold = 0;
    ref.fused = ref.overlap = false;
    const SolveBackend& b = require_backend(cfg.backend);
    if (b.rrv_loop) ref.method = Method::jacobi;  // RRV's loop is Jacobi's
    if (b.one_thread) ref.threads = 1;            // gauss-seidel and sor: the same one block of rows
    ref.history = false;
    SolveResult r = solve(sys, ref);
    v.reference_iterations = r.iterations;
    R = std::move(r.B);
  } else {
    const ErrorReference own = converged ? ErrorReference{} : converged_reference(sys, "the run's form factors");
    if (!converged) converged = &own;
    v.reference_iterations = converged->iterations;
    R = converged->B;
  }
  v.max_rel_diff = max_rel_diff(res.B, R);
  v.bound = cfg.steps > 0 ? (cfg.precision == Precision::double_ ? 1e-10 : 1e-5) : 1e-5 + 20 * cfg.tol;
  v.agreed = v.max_rel_diff <= v.bound;
  v.seconds = t.seconds();
  return v;
}

namespace {

// The error reference from --reference-ff (and --reference-divide's finer mesh), carried onto m.
ErrorReference reference_from_file(const SolvePlan& p, const Mesh& m) {
  Mesh fine;
  if (p.reference_divide > 0) {
    LoadOptions lo = p.scene.load;
    lo.divide = p.reference_divide;
    fine = load_rrv_scene(p.scene.scene, lo);
  }
  const Mesh& rm = p.reference_divide > 0 ? fine : m;
  const double rn = double(rm.size());
  hpcgi::require_host_memory("the error reference on " + std::to_string(rm.size()) + " patches (its dense float32 "
                             "form factors " + gib(4 * rn * rn) + ", vectors " + gib(vector_bytes(rm.size())) + ")",
                             4 * rn * rn + vector_bytes(rm.size()));
  const FormFactorFile rfile = FormFactorFile::open(p.reference_ff).checked(rm).require_dense();
  const FormFactorMatrix rff = read_form_factors(rfile, rm);
  ErrorReference ref = converged_reference(make_system(rm, rff.view()), "");
  char what[96];
  std::snprintf(what, sizeof what, " (hemicube R=%d, %zu patches, divide %g)", rfile.info().params.resolution, rm.size(),
                rm.size() == m.size() ? p.scene.load.divide : p.reference_divide);
  ref.of = p.reference_ff + what;
  if (p.reference_divide > 0 && mesh_hash(fine) != mesh_hash(m)) ref.B = area_weighted_onto(m, fine, ref.B);
  return ref;
}

}  // namespace

void solve_reference_at(ReferencePoint at, const SolvePlan& p, const Loaded& L, References& R) {
  if (!p.verify || R.have) return;
  switch (at) {
    case ReferencePoint::before_form_factors:
      if (p.reference_ff.empty()) return;
      R.ref = reference_from_file(p, L.m);
      R.from_file = true;
      break;
    case ReferencePoint::before_rounding:
      if (L.same_matrix) return;  // the run solves the file's values as they are: its reference can wait for it
      R.ref = hpcgi::comm::agreed([&] { return converged_reference(L.sys, ""); });
      break;
    case ReferencePoint::after_run:
      R.ref = hpcgi::comm::agreed([&] { return converged_reference(L.sys, ""); });
      break;
  }
  R.have = true;
}

Checked verify_solve(const SolvePlan& p, const Loaded& L, References&& R, const SolveResult& res) {
  Checked c;
  c.made = p.verify && !failed(res.status);
  if (c.made) {
    // The reference is the run's converged solution when the run's matrix is the file's and no other file gave it.
    const bool same = L.same_matrix && !R.from_file;
    solve_reference_at(ReferencePoint::after_run, p, L, R);
    if (R.ref.of.empty()) R.ref.of = p.ff + (same ? "" : " before threshold and rounding") + " (" + L.patches + ")";
    c.v = hpcgi::comm::agreed([&] { return verify(L.sys, p.cfg, res, same ? &R.ref : nullptr); });
    c.error = max_rel_diff(res.B, R.ref.B);
  }
  c.ref = std::move(R.ref);
  c.outcome = outcome_of(res, p.cfg, c.made ? &c.v : nullptr);
  return c;
}

hpcgi::Outcome outcome_of(const SolveResult& res, const SolveConfig& cfg, const Verification* v) {
  char why[256];
  if (failed(res.status))  // a stagnant run's detail says it all ("no solution: ...")
    return {hpcgi::kExitNumerical,
            res.status == SolveStatus::stagnant ? res.detail : std::string(to_string(res.status)) + ": " + res.detail};
  if (res.status == SolveStatus::max_iter) {
    std::snprintf(why, sizeof why, "%s stopped at --max-iter %ld with the largest relative residual %.3e, above --tol %.1e",
                  to_string(cfg.method).c_str(), cfg.max_iter,
                  *std::max_element(res.rel_residual.begin(), res.rel_residual.end()), cfg.tol);
    return {hpcgi::kExitNotConverged, why};
  }
  if (v && !v->agreed) {
    std::snprintf(why, sizeof why, "max relative difference %.3e from the float64 reference, above the bound %.1e",
                  v->max_rel_diff, v->bound);
    return {hpcgi::kExitDisagreed, why};
  }
  return {};
}

}  // namespace radiosity::app
