// bin/radiosity: the radiosity pipeline of the report, one step per subcommand.
//   info         load and subdivide a scene, print what it holds and what a run will need
//   formfactors  compute the form factors by the hemicube, once, into a file named for the mesh (under mpirun: each
//                rank its block of rows, one file written together)
//   solve        solve B = E + ρ ⊙ F B with a method, layout, backend and precision; write the scene, pictures and
//                a record; check the answer against the serial float64 result (--backend mpi: on MPI ranks)
//   relight      frames of new lights (from the light basis) and reflectivities (warm solves) over fixed form factors
//                (--backend mpi: the light basis on MPI ranks)
//   web          one self-contained HTML page that relights the scene from its light basis in WebGL
#include <omp.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "common/cli.hpp"
#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/launcher.hpp"
#include "common/record.hpp"
#include "radiosity/app/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Radiosity (report HPCF-2014-15): RRV scenes, hemicube form factors, Jacobi and BiCG-STAB solvers.\n"
               "Typical use:\n"
               "  bin/radiosity formfactors radiosity/scenes/scene1.xml -o scene1.ff\n"
               "  bin/radiosity solve radiosity/scenes/scene1.xml --ff scene1.ff --png scene1.png\n"
               "Across MPI ranks (one thread per rank unless --threads or OMP_NUM_THREADS says otherwise):\n"
               "  mpirun -np 4 bin/radiosity formfactors radiosity/scenes/scene2.xml -o scene2.ff\n"
               "  mpirun -np 4 bin/radiosity solve radiosity/scenes/scene2.xml --ff scene2.ff --backend mpi\n"
               "A form-factor file is the same whoever wrote it: any number of ranks, or one process, reads it.",
               "radiosity"};
  app.footer(hpcgi::exit_status_help());
  app.require_subcommand(1);
  hpcgi::add_list_backends(app, radiosity::app::describe_backends);
  radiosity::app::InfoArgs info;
  radiosity::app::FormFactorArgs ff;
  radiosity::app::SolveArgs solve;
  radiosity::app::add_info(app, info);
  radiosity::app::add_formfactors(app, ff);
  radiosity::app::add_solve(app, solve);
  radiosity::app::RelightArgs relight;
  radiosity::app::add_relight(app, relight);
  radiosity::app::WebArgs web;
  radiosity::app::add_web(app, web);
  int code = 0;
  hpcgi::record::set_command_line(argc, argv);
  if (!hpcgi::parse_cli(app, argc, argv, code)) return code;

  // MPI: the form factors under any MPI launcher (each rank its rows), a solve or relight (its light basis) with
  // --backend mpi. Everything else runs as one process and refuses to be one of several ranks, which would each do
  // the whole run.
  const bool ff_cmd = app.got_subcommand("formfactors"), solve_cmd = app.got_subcommand("solve");
  const bool relight_cmd = app.got_subcommand("relight");
  const auto distributed = [](const std::string& name) {
    const radiosity::SolveBackend* b = radiosity::find_backend(name);
    return b && b->distributed;
  };
  const bool mpi_solve = (solve_cmd && distributed(solve.cfg.backend)) || (relight_cmd && distributed(relight.cfg.backend));
  const bool launched = hpcgi::launcher_world_size() > 0;
  const bool want_mpi = hpcgi::comm::built() && ((ff_cmd && launched) || mpi_solve);
  int status = hpcgi::run_main("radiosity", [&]() -> int {
    if (hpcgi::launched_by_mpirun_with_many_ranks() && !want_mpi) {
      if (!hpcgi::comm::built() && (ff_cmd || mpi_solve))
        throw hpcgi::UsageError("this bin/radiosity was built without MPI (no mpicxx): it runs as one process");
      if (solve_cmd || relight_cmd)
        throw hpcgi::UsageError("backend '" + (solve_cmd ? solve.cfg.backend : relight.cfg.backend) +
                                "' runs as one process; use --backend mpi under mpirun");
      throw hpcgi::UsageError("'info' runs as one process; run it without mpirun");
    }
    return 0;
  });
  if (status != 0) return status;
  // One OpenMP thread per rank by default, as bin/poisson does: P ranks on a node would otherwise start P times
  // as many threads as it has cores.
  const int* threads = ff_cmd        ? &ff.threads
                       : solve_cmd   ? &solve.threads
                       : relight_cmd ? &relight.threads
                                     : &info.threads;  // others: one process
  if (want_mpi && *threads == 0 && !std::getenv("OMP_NUM_THREADS")) omp_set_num_threads(1);
  hpcgi::comm::Session session(want_mpi);  // MPI_Finalize when main returns, after errors are reported
  return hpcgi::run_main("radiosity", [&]() -> int {
    if (ff_cmd) return radiosity::app::run_formfactors(ff);
    if (solve_cmd) return radiosity::app::run_solve(solve);
    if (app.got_subcommand("relight")) return radiosity::app::run_relight(relight);
    if (app.got_subcommand("web")) return radiosity::app::run_web(web);
    return radiosity::app::run_info(info);
  });
}
