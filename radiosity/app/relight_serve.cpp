// Phase 3 of `bin/radiosity relight` (relight_phases.hpp): the frames served in order. A frame that changes only
// lights is mixed from the light basis; a frame that changes a reflectivity is solved, warm-started from the previous
// frame's B. Every --check-every K frames, the error against a cold float64 solve of that frame.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/timer.hpp"
#include "radiosity/app/reference.hpp"
#include "radiosity/app/relight_phases.hpp"
#include "radiosity/render/png_writer.hpp"
#include "radiosity/render/render.hpp"
#include "radiosity/solve/physical.hpp"

namespace radiosity::app {
namespace {

using namespace radiosity::relight;

// Thrown by the iteration callback when the next iteration would pass --frame-budget-ms.
struct BudgetReached {};

std::vector<Rgb> as_rgb(const std::vector<float>& flat) {
  std::vector<Rgb> B(flat.size() / 3);
  for (size_t i = 0; i < B.size(); ++i) B[i] = {flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]};
  return B;
}

// The frame's system on the stored F the reflectivity frames read (RRV's start: a cold solve).
System frame_system(const RelightInputs& in, const Mesh& fm) {
  return make_system(fm, in.frame_view);
}

// One solve of the frame from `prev`, stopped before it would pass the frame budget (budget_s > 0).
SolveResult solve_within_budget(const System& sys, const SolveConfig& cfg, double budget_s, double& ms, bool& stopped) {
  hpcgi::Timer ft;
  double last = 0;
  long its = 0;
  std::vector<Rgb> at_budget;
  IterationCallback cb;
  if (budget_s > 0)
    cb = [&](long it, const std::vector<Rgb>& b) {
      const double now = ft.seconds();
      const double step = (now - last) / double(std::max(1L, it - its));
      last = now, its = it;
      if (now + step > budget_s) {
        at_budget = b;
        throw BudgetReached{};
      }
    };
  SolveResult res;
  stopped = false;
  try {
    res = solve(sys, cfg, cb);
    ms = (ft.seconds() - res.check_s) * 1e3;  // the independent residual check is no part of the frame
  } catch (const BudgetReached&) {
    ms = ft.seconds() * 1e3;
    stopped = true;
    res.B = std::move(at_budget);
    res.iterations = its;
    res.rel_residual = relative_residual(sys, res.B);
    res.status = SolveStatus::max_iter;
  }
  return res;
}

// A reflectivity frame: solved warm from prev; its fields in fr, its tallies in s.
std::vector<Rgb> solved_frame(const RelightArgs& a, const RelightInputs& in, const Mesh& fm, size_t k, bool check,
                              const std::vector<Rgb>& prev, nlohmann::json& fr, ServedFrames& s, double& ms) {
  SolveConfig cfg = a.cfg;
  cfg.threads = a.threads;
  System sys = frame_system(in, fm);
  sys.initial = prev;  // warm start
  bool stopped = false;
  SolveResult res = solve_within_budget(sys, cfg, a.frame_budget_ms * 1e-3, ms, stopped);
  if (failed(res.status)) {  // no answer: the frames stop here, the record is still written with exit status 3
    s.outcome = {hpcgi::kExitNumerical, "frame " + std::to_string(k) + ": " + to_string(res.status) + ": " + res.detail};
    fr["kind"] = "solved";
    fr["iterations"] = res.iterations;
    fr["status"] = to_string(res.status);
    return {};
  }
  const double r = *std::max_element(res.rel_residual.begin(), res.rel_residual.end());
  if (!stopped && res.status == SolveStatus::max_iter && s.outcome.status == hpcgi::kExitOk) {
    char why[256];
    std::snprintf(why, sizeof why, "frame %zu: %s stopped at --max-iter %ld with the largest relative residual "
                  "%.3e, above --tol %.1e", k, to_string(cfg.method).c_str(), cfg.max_iter, r, cfg.tol);
    s.outcome = {hpcgi::kExitNotConverged, why};
  }
  fr["kind"] = "solved";
  fr["iterations"] = res.iterations;
  fr["residual"] = r;
  fr["status"] = stopped ? "budget" : to_string(res.status);
  s.over_tol += r > cfg.tol;
  s.worst_residual = std::max(s.worst_residual, r);
  // The same solve from RRV's cold start: the iterations a frame would cost without the warm start.
  if (check) fr["cold_iterations"] = solve(frame_system(in, fm), cfg).iterations;
  ++s.solved;
  s.solved_ms.push_back(ms);
  return std::move(res.B);
}

void print_frame(size_t k, const nlohmann::json& fr, double ms) {
  std::printf("  frame %zu: %s %.4f ms", k, fr["kind"].get<std::string>().c_str(), ms);
  if (fr.contains("iterations")) std::printf(", %ld iterations", fr["iterations"].get<long>());
  std::printf(", residual %.2e", fr["residual"].get<double>());
  if (fr.contains("cold_iterations")) std::printf(" (cold: %ld iterations)", fr["cold_iterations"].get<long>());
  if (fr.contains("error")) std::printf(", error vs cold float64 %.2e", fr["error"].get<double>());
  std::printf("\n");
}

}  // namespace

std::string png_frame_file(const std::string& prefix, size_t k) {
  char name[32];
  std::snprintf(name, sizeof name, "_%04zu.png", k);
  return prefix + name;
}

ServedFrames serve_frames(const RelightArgs& a, const RelightPlan& p, const RelightInputs& in,
                          const LightBasis& basis) {
  ServedFrames s;
  RenderOptions ropt;
  ropt.exposure = a.exposure;
  std::vector<float> mixed;
  mix(basis, std::vector<LightSetting>(in.lights.size()), mixed, 1);  // the frame before the first: the scene as is
  std::vector<Rgb> prev = as_rgb(mixed);
  for (size_t k = 0; k < in.frames.size(); ++k) {
    const Frame& f = in.frames[k];
    const bool check = a.check_every > 0 && k % size_t(a.check_every) == 0;
    nlohmann::json fr = {{"frame", k}};
    std::vector<Rgb> B;
    double ms = 0;
    const Mesh fm = frame_mesh(in.m, in.named, f);  // the frame's emission and reflectivity
    if (f.scene_reflectivity) {
      hpcgi::Timer ft;
      mix(basis, f.lights, mixed, 1);  // one thread: see the record's perf.timer
      ms = ft.seconds() * 1e3;
      B = as_rgb(mixed);
      fr["kind"] = "basis";
      fr["residual"] = basis.max_residual;
      s.basis_ms.push_back(ms);
    } else {
      B = solved_frame(a, in, fm, k, check, prev, fr, s, ms);
      if (s.outcome.status == hpcgi::kExitNumerical) {
        s.per_frame.push_back(fr);
        break;
      }
    }
    // The one physical check (solve's frames had it in solve; a mixed frame is checked here, its sums in float):
    // finite, and B >= E within the basis's residual and the rounding.
    const double r = fr["residual"].get<double>();
    const PhysicalCheck pc = check_physical(frame_system(in, fm), B, Rgb{r, r, r}, a.cfg.tol, Precision::single);
    if (pc.status != SolveStatus::converged) {
      s.outcome = {hpcgi::kExitNumerical, "frame " + std::to_string(k) + ": " + to_string(pc.status) + ": " + pc.detail};
      fr["status"] = to_string(pc.status);
      s.per_frame.push_back(fr);
      break;
    }
    fr["ms"] = ms;
    s.all_ms.push_back(ms);
    if (check) {
      const double err = max_rel_diff(B, converged_reference(make_system(fm, in.file_matrix->dense_float32_values()), "").B);
      fr["error"] = err;
      s.worst_error = std::isnan(err) ? err : std::max(s.worst_error, err);
      ++s.checked;
    }
    if (a.record_patches > 0) {
      nlohmann::json head = nlohmann::json::array();
      for (size_t i = 0; i < std::min(in.m.size(), size_t(a.record_patches)); ++i) head.push_back(B[i]);
      fr["radiosity"] = head;
    }
    if (!a.png_frames.empty()) {
      s.pngs.push_back(png_frame_file(a.png_frames, k));
      write_png(s.pngs.back(), render(in.m, B, in.cam, p.width, p.height, ropt));
    }
    if (!a.quiet && in.frames.size() <= 50) print_frame(k, fr, ms);
    s.per_frame.push_back(fr);
    prev = std::move(B);
  }
  return s;
}

}  // namespace radiosity::app
