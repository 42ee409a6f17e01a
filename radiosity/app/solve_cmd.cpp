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
  const SolvePlan plan = plan_solve(a);
  Problem problem = load_mesh(a, plan);
  References refs;
  solve_reference_at(ReferencePoint::before_form_factors, a, problem, refs);  // --reference-ff's, freed before ours
  read_form_factors(a, plan, problem);
  solve_reference_at(ReferencePoint::before_rounding, a, problem, refs);  // on the file's values, before the build
  build_matrix(a, plan, problem);
  const Problem& loaded = problem;
  const SolveRun run = run_solver(a, plan, loaded);
  const Checked checked = verify_solve(a, plan, loaded, std::move(refs), run.res);
  const SolveReport report{a, plan, loaded, run, checked, total.seconds()};
  finish_solve(report, solve_record(report));
  return 0;
}

}  // namespace radiosity::app
