// bin/radiosity: the radiosity pipeline of the report, one step per subcommand.
//   info         load and subdivide a scene, print what it holds and what a run will need
//   formfactors  compute the form factors by the hemicube, once, into a file named for the mesh
//   solve        solve B = E + ρ ⊙ F B with a method, layout, backend and precision; write the scene, pictures and
//                a record; check the answer against the serial float64 result
#include <omp.h>

#include <cstdio>
#include <string>

#include "common/cli.hpp"
#include "common/record.hpp"
#include "radiosity/app/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Radiosity (report HPCF-2014-15): RRV scenes, hemicube form factors, Jacobi and BiCG-STAB solvers.\n"
               "Typical use:\n"
               "  bin/radiosity formfactors radiosity/scenes/scene1.xml -o scene1.ff\n"
               "  bin/radiosity solve radiosity/scenes/scene1.xml --ff scene1.ff --png scene1.png",
               "radiosity"};
  app.require_subcommand(1);
  radiosity::app::InfoArgs info;
  radiosity::app::FormFactorArgs ff;
  radiosity::app::SolveArgs solve;
  radiosity::app::add_info(app, info);
  radiosity::app::add_formfactors(app, ff);
  radiosity::app::add_solve(app, solve);
  int code = 0;
  hpcgi::record::set_command_line(argc, argv);
  if (!hpcgi::parse_cli(app, argc, argv, code)) return code;
  return hpcgi::run_main("radiosity", [&]() -> int {
    if (app.got_subcommand("info")) return radiosity::app::run_info(info);
    if (app.got_subcommand("formfactors")) return radiosity::app::run_formfactors(ff);
    return radiosity::app::run_solve(solve);
  });
}
