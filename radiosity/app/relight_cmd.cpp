// `bin/radiosity relight`: frames of new light settings and reflectivities over fixed form factors (issue 20).
// Frames that change only lights are mixed from the light basis (radiosity/relight/basis.hpp); frames that change a
// reflectivity are solved, warm-started from the previous frame's B. Per frame: time, iterations, residual and,
// every --check-every K frames, the error against a cold float64 solve of that frame.
// --bench-rhs K times linalg.hpp's product with K right-hand sides instead (make bench).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "common/cli.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/app/reference.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/relight/basis_file.hpp"
#include "radiosity/relight/frames.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/render/png_writer.hpp"
#include "radiosity/render/render.hpp"
#include "radiosity/solve/cpu/exec.hpp"
#include "radiosity/solve/cpu/linalg.hpp"

namespace radiosity::app {
namespace {

using namespace radiosity::relight;

// Thrown by the iteration callback when the next iteration would pass --frame-budget-ms.
struct BudgetReached {};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t k = size_t(std::ceil(p / 100 * double(v.size()))) - (p > 0 ? 1 : 0);
  return v[std::min(k, v.size() - 1)];
}

std::vector<Rgb> as_rgb(const std::vector<float>& flat) {
  std::vector<Rgb> B(flat.size() / 3);
  for (size_t i = 0; i < B.size(); ++i) B[i] = {flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]};
  return B;
}

System frame_system(const Mesh& fm, const float* F) {
  System sys = make_system(fm, F);  // B0 = RRV's start: a cold solve
  return sys;
}

// The product with k right-hand sides, timed (make bench): passes products after one untimed warm-up.
int bench_product(const RelightArgs& a, const Mesh& m, const FFMatrixView& view, nlohmann::json& rec) {
  const size_t n = m.size(), k = size_t(a.bench_rhs);
  const OpenMPExec ex(a.threads);
  std::vector<Rgb> rho_host(n), e(n);
  for (size_t i = 0; i < n; ++i) rho_host[i] = m.patches[i].reflectivity, e[i] = m.patches[i].emission;
  const std::vector<int32_t> rows = dense_rows_to_compute(rho_host);
  Soa<float> rho(n);
  load(ex, rho, rho_host);
  std::vector<Soa<float>> X, Y, E, X1, Y1, E1;  // X1 ...: the first right-hand side alone (k = 1)
  for (size_t q = 0; q < k; ++q) {
    std::vector<Rgb> x(n);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) x[i][c] = e[i][c] + 0.01 * double((i * 7 + q * 13 + c) % 101);
    X.emplace_back(n), Y.emplace_back(n), E.emplace_back(n);
    load(ex, X.back(), x), load(ex, E.back(), e), load(ex, Y.back(), x);
    if (q == 0) {
      X1.emplace_back(n), Y1.emplace_back(n), E1.emplace_back(n);
      load(ex, X1.back(), x), load(ex, E1.back(), e), load(ex, Y1.back(), x);
    }
  }
  // The k-product and the same product with k = 1 in turns, pass by pass, so that their ratio compares passes that
  // ran under the same load (this project's VM is shared); pass 0 warms the caches and the threads.
  std::vector<double> ms, one_ms;
  for (long p = 0; p <= a.passes; ++p) {
    hpcgi::Timer t;
    multi_affine_matvec<OpenMPExec, float>(ex, view, rows, X, Y, rho, E, 0.0f, 1.0f, 1.0f);
    const double tk = t.seconds() * 1e3;
    t.reset();
    multi_affine_matvec<OpenMPExec, float>(ex, view, rows, X1, Y1, rho, E1, 0.0f, 1.0f, 1.0f);
    if (p > 0) ms.push_back(tk), one_ms.push_back(t.seconds() * 1e3);
  }
  // The same values through the one-right-hand-side product every solver runs (affine_matvec), for comparison.
  std::vector<double> single_ms;
  {
    Aos<float> x(n), y(n), r(n), ee(n);
    std::vector<Rgb> xh(n);
    for (size_t i = 0; i < n; ++i) xh[i] = {e[i][0] + 0.5, e[i][1] + 0.5, e[i][2] + 0.5};
    load(ex, x, xh), load(ex, r, rho_host), load(ex, ee, e);
    for (long p = 0; p <= a.passes; ++p) {
      hpcgi::Timer t;
      affine_matvec(ex, view, rows, x, y, r, ee, 0.0f, 1.0f, 1.0f);
      if (p > 0) single_ms.push_back(t.seconds() * 1e3);
    }
  }
  const double med = percentile(ms, 50), bytes = double(n) * double(n) * double(value_bytes(view.values));
  rec["result"] = {{"rhs", k},
                   {"product_ms_median", med},
                   {"product_ms", ms},
                   {"per_rhs_ms", med / double(k)},
                   {"single_product_ms_median", percentile(single_ms, 50)},
                   {"k1_product_ms_median", percentile(one_ms, 50)},
                   {"over_k1_alternating", med / percentile(one_ms, 50)},
                   {"matrix_bytes", bytes},
                   {"bandwidth_GBps", bytes / (med * 1e-3) / 1e9},
                   {"threads", ex.threads()}};
  if (!a.quiet)
    std::printf("relight --bench-rhs %zu: %s F of %zu patches, %d threads: product %.3f ms (median of %ld), %.3f ms per "
                "right-hand side, %.2f GB/s of F; k = 1 in turns with it %.3f ms (ratio %.2f); one-right-hand-side solver "
                "product %.3f ms\n",
                k, to_string(view.values), n, ex.threads(), med, a.passes, med / double(k), bytes / (med * 1e-3) / 1e9,
                percentile(one_ms, 50), med / percentile(one_ms, 50), percentile(single_ms, 50));
  return 0;
}

}  // namespace

void add_relight(CLI::App& app, RelightArgs& a) {
  CLI::App* cmd = app.add_subcommand(
      "relight",
      "frames of new light intensities/colours (served from the light basis) and reflectivities (solved warm from the "
      "previous frame) over the scene's fixed form factors");
  cmd->footer(hpcgi::exit_status_help());
  add_scene_options(cmd, a);
  cmd->add_option("--ff", a.ff, "form-factor file written by `bin/radiosity formfactors` for this scene")->required();
  auto* frames = cmd->add_option("--frames", a.frames,
                                 "frames JSON: {\"frames\": [{\"lights\": {NAME: {\"intensity\": x, \"rgb\": [r,g,b]}}, "
                                 "\"reflectivity\": {NAME: [r,g,b]}}, ...]} (names as `bin/radiosity info` lists them)");
  auto* random = cmd->add_option("--random-frames", a.random_frames,
                                 "N frames of random light mixes (intensity in [0,2), colour in [0,1)^3), no file")
                     ->check(CLI::PositiveNumber)->excludes(frames);
  cmd->add_option("--seed", a.seed, "seed of --random-frames")->capture_default_str();
  cmd->add_option("--basis", a.basis,
                  "light-basis file: read when it exists (it must belong to this mesh, form factors and colours), "
                  "else solved and written there");
  cmd->add_option("--basis-tol", a.basis_tol, "relative residual every light's solve reaches (Jacobi, float64)")
      ->check(hpcgi::positive_finite())->capture_default_str();
  cmd->add_option("--method", a.cfg.method, "reflectivity frames: jacobi | bicgstab")
      ->check(CLI::IsMember({"jacobi", "bicgstab"}))->capture_default_str();
  cmd->add_option("--backend", a.cfg.backend, "reflectivity frames: a backend of `solve`")->capture_default_str();
  cmd->add_option("--precision", a.cfg.precision, "reflectivity frames: float | double")
      ->check(CLI::IsMember({"float", "double"}))->capture_default_str();
  cmd->add_option("--ff-precision", a.ff_precision, "reflectivity frames: F stored as float32 | float16 | bfloat16")
      ->check(CLI::IsMember({"float32", "float16", "bfloat16"}))->capture_default_str();
  a.cfg.tol = 1e-4;
  cmd->add_option("--tol", a.cfg.tol, "reflectivity frames: stop at this relative residual")
      ->check(hpcgi::positive_finite())->capture_default_str();
  cmd->add_option("--max-iter", a.cfg.max_iter, "reflectivity frames: iteration limit")->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--frame-budget-ms", a.frame_budget_ms,
                  "reflectivity frames: stop before an iteration would pass MS milliseconds (or at --tol), and report "
                  "the residual reached")
      ->check(hpcgi::positive_finite());
  cmd->add_option("--check-every", a.check_every,
                  "every K-th frame (0, K, 2K, ...): the error against a cold float64 solve of that frame, and for a "
                  "reflectivity frame the iterations of the same solve started cold")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd->add_option("--record-patches", a.record_patches, "put the radiosity of the first P patches of each frame in the record")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--png-frames", a.png_frames, "render frame K to PREFIX_K.png (K with 4 digits)");
  cmd->add_option("--view", a.view, "camera of --png-frames: auto | front | top | inside | ex,ey,ez:tx,ty,tz[:fov]")
      ->capture_default_str();
  cmd->add_option("--size", a.size, "picture size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--exposure", a.exposure, "multiply radiosity by E before display")
      ->check(hpcgi::positive_finite())->capture_default_str();
  auto* bench = cmd->add_option("--bench-rhs", a.bench_rhs,
                                "time the product with K right-hand sides (one pass over F, --ff-precision) instead "
                                "of frames (make bench)")
                    ->check(CLI::Range(1, 64))->excludes(frames)->excludes(random);
  cmd->add_option("--passes", a.passes, "--bench-rhs: timed products")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->callback([&a, frames, random, bench] {
    if (frames->count() + random->count() + bench->count() == 0)
      throw CLI::ValidationError("give --frames FILE, --random-frames N or --bench-rhs K");
  });
}

int run_relight(const RelightArgs& a) {
  hpcgi::Timer total;
  int width = 0, height = 0;
  {
    char x = 0, extra = 0;
    if (std::sscanf(a.size.c_str(), "%d%c%d%c", &width, &x, &height, &extra) != 3 || x != 'x' || width < 1 ||
        height < 1 || width > 16384 || height > 16384)
      throw hpcgi::UsageError("--size must be WIDTHxHEIGHT with 1..16384 pixels each, got '" + a.size + "'");
  }
  const FFValues values = parse_ff_values(a.ff_precision);
  // The reflectivity frames' backend is checked before anything is read or written (solve() checks the rest).
  const SolveBackend* backend = nullptr;
  for (const SolveBackend& b : solve_backends())
    if (b.name == a.cfg.backend) backend = &b;
  if (!backend) throw hpcgi::UsageError("unknown solver backend '" + a.cfg.backend + "'");
  if (!backend->built)
    throw hpcgi::UsageError("solver backend '" + backend->name + "' is not available: " + backend->why_not);
  if (!backend->any_storage && values != FFValues::float32)
    throw hpcgi::UsageError("backend '" + backend->name + "' reads dense float32 form factors only: --ff-precision "
                            "float16|bfloat16 runs on serial and openmp");
  // --basis is read when it exists and written when not: either way a file, and neither --ff nor --frames.
  check_files(a, {{a.basis, "--basis"}}, {{a.ff, "--ff"}, {a.frames, "--frames"}});
  double load_s = 0;
  const Mesh m = load_scene(a, &load_s);
  const size_t n = m.size();
  const std::vector<NamedEntity> named = named_entities(m), lights = lights_of(named);
  // Every frame is read and checked before anything is computed or written.
  const std::vector<Frame> frames = a.bench_rhs > 0       ? std::vector<Frame>{}
                                    : a.random_frames > 0 ? random_frames(size_t(a.random_frames), uint64_t(a.seed), named)
                                                          : read_frames(a.frames, m, named, a.load.allow_reflectivity_ge_1);
  const Camera cam = parse_view(a.view, m);
  const double n2 = double(n) * double(n);
  hpcgi::require_host_memory("relighting " + std::to_string(n) + " patches (dense float32 form factors and a 16-bit "
                             "copy)", 4 * n2 + (values != FFValues::float32 ? 2 * n2 : 0));
  hpcgi::Timer t;
  FormFactors ff = load_form_factors(a.ff, m);
  const double ff_load_s = t.seconds();
  std::unique_ptr<FormFactorMatrix> matrix;
  if (values != FFValues::float32) {
    std::vector<Rgb> rho(n);
    for (size_t i = 0; i < n; ++i) rho[i] = m.patches[i].reflectivity;
    FFMatrixOptions opt;
    opt.values = values;
    matrix = std::make_unique<FormFactorMatrix>(ff.values.data(), n, rho, opt);
  }
  const FFMatrixView file_view = dense_float32_view(ff.values.data(), n);
  const FFMatrixView frame_view = matrix ? matrix->view() : file_view;

  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "relight"},       {"scene", a.scene},
                   {"patches", n},               {"divide", a.load.divide},
                   {"ff_file", a.ff},            {"hemicube", ff.params.resolution},
                   {"weights", to_string(ff.params.weights)},
                   {"ff_precision", a.ff_precision}};
  if (a.bench_rhs > 0) {
    rec["params"]["bench_rhs"] = a.bench_rhs;
    rec["params"]["passes"] = a.passes;
    bench_product(a, m, frame_view, rec);
    rec["times_s"] = {{"load", load_s}, {"ff_load", ff_load_s}, {"total", total.seconds()}};
    hpcgi::record::emit(rec, a);
    return 0;
  }

  BasisOptions bopt;
  bopt.tol = a.basis_tol;
  bopt.threads = a.threads;
  bool loaded = false;
  const LightBasis basis = load_or_solve_basis(a.basis, m, a.ff, file_view, lights, bopt, &loaded);

  SolveConfig cfg = a.cfg;
  cfg.threads = a.threads;
  RenderOptions ropt;
  ropt.exposure = a.exposure;
  std::vector<float> mixed;
  // The frame before the first: the scene as it is, from the basis.
  mix(basis, std::vector<LightSetting>(lights.size()), mixed, 1);
  std::vector<Rgb> prev = as_rgb(mixed);
  std::vector<double> all_ms, basis_ms, solved_ms;
  double worst_error = 0, worst_residual = 0;
  long checked = 0, solved = 0, over_tol = 0;
  hpcgi::Outcome outcome;  // 4 when a solved frame stopped at --max-iter (not at --frame-budget-ms)
  nlohmann::json per_frame = nlohmann::json::array();
  std::vector<std::string> pngs;
  for (size_t k = 0; k < frames.size(); ++k) {
    const Frame& f = frames[k];
    const bool check = a.check_every > 0 && k % size_t(a.check_every) == 0;
    nlohmann::json fr = {{"frame", k}};
    std::vector<Rgb> B;
    double ms = 0;
    Mesh fm;
    if (check || !f.scene_reflectivity) fm = frame_mesh(m, named, f);
    if (f.scene_reflectivity) {
      hpcgi::Timer ft;
      mix(basis, f.lights, mixed, 1);  // one thread: see the record's perf.timer
      ms = ft.seconds() * 1e3;
      B = as_rgb(mixed);
      fr["kind"] = "basis";
      fr["residual"] = basis.max_residual;
      basis_ms.push_back(ms);
    } else {
      System sys = frame_system(fm, ff.values.data());
      if (matrix) {
        sys.F = nullptr;
        sys.stored = frame_view;
      }
      sys.initial = prev;  // warm start
      const double budget_s = a.frame_budget_ms * 1e-3;
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
      bool stopped = false;
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
      if (failed(res.status))
        throw hpcgi::NumericalError("frame " + std::to_string(k) + ": " + to_string(res.status) + ": " + res.detail);
      const double r = *std::max_element(res.rel_residual.begin(), res.rel_residual.end());
      if (!stopped && res.status == SolveStatus::max_iter && outcome.status == hpcgi::kExitOk) {
        char why[256];
        std::snprintf(why, sizeof why, "frame %zu: %s stopped at --max-iter %ld with the largest relative residual "
                      "%.3e, above --tol %.1e", k, cfg.method.c_str(), cfg.max_iter, r, cfg.tol);
        outcome = {hpcgi::kExitNotConverged, why};
      }
      fr["kind"] = "solved";
      fr["iterations"] = res.iterations;
      fr["residual"] = r;
      fr["status"] = stopped ? "budget" : to_string(res.status);
      over_tol += r > cfg.tol;
      worst_residual = std::max(worst_residual, r);
      if (check) {  // the same solve from RRV's cold start, for the iterations a frame would cost without warm start
        System cold_sys = frame_system(fm, ff.values.data());
        if (matrix) {
          cold_sys.F = nullptr;
          cold_sys.stored = frame_view;
        }
        const SolveResult cold = solve(cold_sys, cfg);
        fr["cold_iterations"] = cold.iterations;
      }
      B = std::move(res.B);
      ++solved;
      solved_ms.push_back(ms);
    }
    fr["ms"] = ms;
    all_ms.push_back(ms);
    if (check) {
      const ErrorReference ref = converged_reference(frame_system(fm, ff.values.data()), "");
      const double err = max_rel_diff(B, ref.B);
      fr["error"] = err;
      worst_error = std::isnan(err) ? err : std::max(worst_error, err);
      ++checked;
    }
    if (a.record_patches > 0) {
      nlohmann::json head = nlohmann::json::array();
      for (size_t i = 0; i < std::min(n, size_t(a.record_patches)); ++i) head.push_back(B[i]);
      fr["radiosity"] = head;
    }
    if (!a.png_frames.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "_%04zu.png", k);
      pngs.push_back(a.png_frames + name);
      write_png(pngs.back(), render(m, B, cam, width, height, ropt));
    }
    if (!a.quiet && frames.size() <= 50) {
      std::printf("  frame %zu: %s %.4f ms", k, fr["kind"].get<std::string>().c_str(), ms);
      if (fr.contains("iterations")) std::printf(", %ld iterations", fr["iterations"].get<long>());
      std::printf(", residual %.2e", fr["residual"].get<double>());
      if (fr.contains("cold_iterations")) std::printf(" (cold: %ld iterations)", fr["cold_iterations"].get<long>());
      if (fr.contains("error")) std::printf(", error vs cold float64 %.2e", fr["error"].get<double>());
      std::printf("\n");
    }
    per_frame.push_back(fr);
    prev = std::move(B);
  }
  double sum_ms = 0;
  for (double x : all_ms) sum_ms += x;
  auto latency = [](const std::vector<double>& v) {
    return nlohmann::json{{"count", v.size()}, {"p50_ms", percentile(v, 50)}, {"p99_ms", percentile(v, 99)},
                          {"max_ms", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}};
  };
  rec["params"].update({{"frames", a.frames.empty() ? nlohmann::json() : nlohmann::json(a.frames)},
                        {"random_frames", a.random_frames > 0 ? nlohmann::json(a.random_frames) : nlohmann::json()},
                        {"seed", a.seed},
                        {"basis_file", a.basis.empty() ? nlohmann::json() : nlohmann::json(a.basis)},
                        {"basis_tol", a.basis_tol},
                        {"method", cfg.method},
                        {"backend", cfg.backend},
                        {"precision", cfg.precision},
                        {"tol", cfg.tol},
                        {"max_iter", cfg.max_iter},
                        {"frame_budget_ms", a.frame_budget_ms > 0 ? nlohmann::json(a.frame_budget_ms) : nlohmann::json()},
                        {"check_every", a.check_every},
                        {"threads", OpenMPExec(a.threads).threads()}});
  nlohmann::json light_names = nlohmann::json::array();
  for (const NamedEntity& l : lights) light_names.push_back(l.name);
  rec["result"] = {{"frames", frames.size()},
                   {"lights", light_names},
                   {"mesh_hash", mesh_hash(m)},
                   {"basis", {{"loaded", loaded}, {"iterations", basis.iterations}, {"max_residual", basis.max_residual},
                              {"tol", basis.tol}, {"seconds", basis.seconds}}},
                   {"latency", latency(all_ms)},
                   {"latency_basis", latency(basis_ms)},
                   {"latency_solved", latency(solved_ms)},
                   {"fps", sum_ms > 0 ? 1e3 * double(frames.size()) / sum_ms : 0.0},
                   {"solved_frames", solved},
                   {"solved_over_tol", over_tol},
                   {"worst_solved_residual", solved ? nlohmann::json(worst_residual) : nlohmann::json()},
                   {"checked_frames", checked},
                   {"worst_error", checked ? nlohmann::json(worst_error) : nlohmann::json()},
                   {"per_frame", per_frame}};
  rec["times_s"] = {{"load", load_s}, {"ff_load", ff_load_s}, {"basis", basis.seconds}, {"total", total.seconds()}};
  rec["perf"] = {{"timer", "host wall clock; a basis frame is the mix alone (one thread), a solved frame its solve's setup and "
                           "iterations without the float64 residual check; rendering and checks excluded"}};
  if (!a.quiet) {
    std::printf("relight: %s, %zu patches, %zu lights (%s), %zu frames\n", a.scene.c_str(), n, lights.size(),
                name_list(lights).c_str(), frames.size());
    std::printf("  light basis: %s, %ld Jacobi steps to %.1e (largest residual %.2e), %.3f s\n",
                loaded ? ("read from " + a.basis).c_str() : "solved", basis.iterations, basis.tol, basis.max_residual,
                basis.seconds);
    std::printf("  basis frames %zu: p50 %.4f ms, p99 %.4f ms; solved frames %zu: p50 %.3f ms, p99 %.3f ms; %.1f frames/s\n",
                basis_ms.size(), percentile(basis_ms, 50), percentile(basis_ms, 99), solved_ms.size(),
                percentile(solved_ms, 50), percentile(solved_ms, 99), sum_ms > 0 ? 1e3 * double(frames.size()) / sum_ms : 0.0);
    if (checked) std::printf("  worst error against a cold float64 solve over %ld checked frames: %.3e\n", checked, worst_error);
    if (!pngs.empty()) std::printf("  frames rendered: %s .. %s\n", pngs.front().c_str(), pngs.back().c_str());
  }
  hpcgi::record::set_outcome(rec, outcome);
  hpcgi::record::emit(rec, a);
  hpcgi::finish(outcome);
  return 0;
}

}  // namespace radiosity::app
