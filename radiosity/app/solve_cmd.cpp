// `bin/radiosity solve`: one solve of a scene whose form factors are in a file, checked against the float64
// reference, with the scene, pictures and a record written on request. The solve runs in phases, each in its file:
// the options (solve_options.cpp), the plan that refuses a request (solve_plan.cpp), the load of the scene and the
// form factors (solve_load.cpp: its steps, with the error reference's phase between them where memory asks for it),
// the solve (solve_run.cpp), the float64 check and the error reference (solve_verify.cpp), the record and the
// summary (solve_report.cpp).
#include <utility>

#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/app/solve_load.hpp"
#include "radiosity/app/solve_plan.hpp"
#include "radiosity/app/solve_report.hpp"
#include "radiosity/app/solve_run.hpp"
#include "radiosity/app/solve_verify.hpp"

namespace radiosity::app {

int run_solve(const SolveArgs& a) {
  hpcgi::Timer total;
  const SolvePlan plan = plan_solve(a);  // the only reader of the options
  Loaded mesh = load_mesh(plan);
  References refs;
  solve_reference_at(ReferencePoint::before_form_factors, plan, mesh, refs);  // --reference-ff's, freed before ours
  Loaded read = read_form_factors(plan, std::move(mesh));
  solve_reference_at(ReferencePoint::before_rounding, plan, read, refs);  // on the file's values, before the build
  const Loaded loaded = build_matrix(plan, std::move(read));
  const SolveRun run = run_solver(plan, loaded);
  const Checked checked = verify_solve(plan, loaded, std::move(refs), run.res);
  const SolveReport report{plan, loaded, run, checked, total.seconds()};
  finish_solve(report, solve_record(report));
  return 0;
}

}  // namespace radiosity::app
