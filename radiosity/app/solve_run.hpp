// Phase 3 of `bin/radiosity solve` (solve_cmd.cpp): the solve. The plan's backend and method (the library's
// registry, radiosity/solve/solve.hpp) on the loaded system, with the snapshots of --snapshots drawn on the way.
#pragma once
#include <string>
#include <vector>

#include "common/repetitions.hpp"
#include "radiosity/app/solve_load.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/render/render.hpp"

namespace radiosity::app {

struct SolveRun {
  SolveResult res;
  Camera cam;                               // --view on the mesh (the pictures)
  RenderOptions ropt;                       // --exposure
  std::vector<std::string> snapshot_files;  // the snapshots drawn, in order
  hpcgi::Repetitions reps;                  // --min-time: the repetitions' times (res is the median one's)
};

// Solves L.sys as p.cfg says, on every rank. A snapshot that could not be written is thrown after the solve.
SolveRun run_solver(const SolvePlan& p, const Loaded& L);

}  // namespace radiosity::app
