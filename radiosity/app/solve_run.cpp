#include "radiosity/app/solve_run.hpp"

#include <exception>
#include <map>
#include <string>

#include "common/comm.hpp"
#include "radiosity/render/png_writer.hpp"

namespace radiosity::app {

SolveRun run_solver(const SolvePlan& p, const Loaded& L) {
  SolveRun run;
  run.cam = hpcgi::comm::agreed([&] { return parse_view(p.view, L.m); });
  run.ropt.exposure = p.exposure;
  const std::map<long, std::string> snaps(p.snapshots.begin(), p.snapshots.end());
  IterationCallback cb;
  // On every rank (fetching B is collective), drawn by rank 0. A failure to write is kept until the solve ends: a
  // rank that left the solve early would leave the others waiting in its collectives.
  std::exception_ptr snapshot_error;
  if (!snaps.empty())
    cb = [&](long it, const std::vector<Rgb>& B) {
      const auto snap = snaps.find(it);
      if (snap == snaps.end()) return;
      const std::string& f = snap->second;
      try {
        if (p.root && !snapshot_error) write_png(f, render(L.m, B, run.cam, p.width, p.height, run.ropt));
      } catch (...) {
        snapshot_error = std::current_exception();
      }
      run.snapshot_files.push_back(f);
    };
  // Agreed: a refused configuration is refused by every rank before any collective (solve checks first).
  // Every solve starts from the same b_0 (cfg.start): a repetition of --min-time solves the same system again.
  run.res = hpcgi::repeat_for(
      p.min_time, [&] { return hpcgi::comm::agreed([&] { return solve(L.sys, p.cfg, cb); }); },
      [](const SolveResult& r) { return r.setup_s + r.solve_s; }, run.reps);
  hpcgi::comm::agreed([&] {
    if (snapshot_error) std::rethrow_exception(snapshot_error);
  });
  return run;
}

}  // namespace radiosity::app
