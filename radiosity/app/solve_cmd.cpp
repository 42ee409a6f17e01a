// `bin/radiosity solve`: one solve of a scene whose form factors are in a file, checked against the float64
// reference, with the scene, pictures and a record written on request.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <set>

#include "common/cli.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/render/png_writer.hpp"
#include "radiosity/render/render.hpp"
#include "radiosity/scene/rrv_writer.hpp"

namespace radiosity::app {
namespace {

std::string backend_list() {
  std::string s;
  for (const auto& b : solve_backends()) s += (s.empty() ? "" : " | ") + b.name;
  return s;
}

std::pair<int, int> parse_size(const std::string& s) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(s.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || x != 'x' || w < 1 || h < 1 || w > 16384 ||
      h > 16384)
    throw hpcgi::UsageError("--size must be WIDTHxHEIGHT with 1..16384 pixels each, got '" + s + "'");
  return {w, h};
}

// max over patches and channels of |B - R|, over max |R|.
double max_rel_diff(const std::vector<Rgb>& B, const std::vector<Rgb>& R) {
  double num = 0, den = 0;
  for (size_t i = 0; i < B.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      num = std::max(num, std::abs(B[i][c] - R[i][c]));
      den = std::max(den, std::abs(R[i][c]));
    }
  return den > 0 ? num / den : num;
}

// The float64 reference of a run: the same method on the same system in double (AOS, openmp backend, which
// agrees bit for bit with serial), for the same steps, or converged to 1e-12 when the run stops on a tolerance.
struct Verification {
  double max_rel_diff = 0, bound = 0, seconds = 0;
  long reference_iterations = 0;
  bool agreed = false;
};
Verification verify(const System& sys, const SolveConfig& cfg, const SolveResult& res) {
  hpcgi::Timer t;
  SolveConfig ref = cfg;
  ref.backend = "openmp";
  ref.layout = "aos";
  ref.precision = "double";
  ref.ff_threshold = 0;
  ref.fused = ref.overlap = false;
  if (cfg.backend == "original") ref.method = "jacobi";
  // A fixed-step run is compared with the same steps in double: only rounding may differ. A run that stops on a
  // tolerance is compared with the converged solution: it may differ by about tol times the condition number of
  // I - diag(ρ)F, at most (1 + ρ)/(1 - ρ) ≈ 19 for ρ ≤ 0.9.
  if (cfg.steps == 0) {
    ref.tol = 1e-12;
    ref.max_iter = std::max(cfg.max_iter, 10000L);
  }
  const SolveResult r = solve(sys, ref);
  Verification v;
  v.max_rel_diff = max_rel_diff(res.B, r.B);
  v.bound = cfg.steps > 0 ? (cfg.precision == "double" ? 1e-10 : 1e-5) : 1e-5 + 20 * cfg.tol;
  v.agreed = v.max_rel_diff <= v.bound;
  v.reference_iterations = r.iterations;
  v.seconds = t.seconds();
  return v;
}

}  // namespace

void add_solve(CLI::App& app, SolveArgs& a) {
  CLI::App* cmd = app.add_subcommand("solve", "solve for the radiosity of a scene whose form factors are in a file");
  add_scene_options(cmd, a);
  cmd->add_option("--ff", a.ff, "form-factor file written by `bin/radiosity formfactors` for this scene")
      ->required();
  cmd->add_option("--method", a.cfg.method, "jacobi | bicgstab")->check(CLI::IsMember({"jacobi", "bicgstab"}))
      ->capture_default_str();
  auto* steps = cmd->add_option("--steps", a.cfg.steps, "exactly K Jacobi steps (RRV: 32), no tolerance")
                    ->check(CLI::PositiveNumber);
  cmd->add_option("--tol", a.cfg.tol, "stop when every channel's ||e - A b|| / ||e|| <= tol")
      ->check(hpcgi::positive_finite())->capture_default_str()->excludes(steps);
  cmd->add_option("--max-iter", a.cfg.max_iter, "iteration limit with --tol")->check(CLI::PositiveNumber)
      ->capture_default_str();
  CLI::Option* layout =
      cmd->add_option("--layout", a.cfg.layout,
                      "aos (one r,g,b record per patch) | soa (one array per channel); default: aos, or the one "
                      "layout a backend runs (cublas: soa)")
          ->check(CLI::IsMember({"aos", "soa"}))->capture_default_str();
  cmd->add_option("--backend", a.cfg.backend, backend_list())->capture_default_str();
  cmd->add_option("--precision", a.cfg.precision, "working precision of B: float | double (F is float32)")
      ->check(CLI::IsMember({"float", "double"}))->capture_default_str();
  CLI::Option* fused =
      cmd->add_flag("--fused", a.cfg.fused, "cublas: one cublasSgemm over the three channels, not an Sgemv per channel");
  CLI::Option* distribution =
      cmd->add_option("--distribution", a.cfg.distribution,
                      "hybrid: the share d in [0, 1] of rows on the GPU (the first ceil(d n))")
          ->capture_default_str();
  CLI::Option* overlap =
      cmd->add_flag("--overlap", a.cfg.overlap, "hybrid: exchange the halves through pinned memory, overlapping the CPU");
  cmd->add_option("--output", a.output_xml, "write the solved scene in RRV's format (RRV's visualizer reads it)");
  cmd->add_option("--png", a.png, "render the solved scene to a PNG");
  cmd->add_option("--view", a.view, "camera: auto | front | top | inside | ex,ey,ez:tx,ty,tz[:fov]")
      ->capture_default_str();
  cmd->add_option("--size", a.size, "picture size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--exposure", a.exposure, "multiply radiosity by E before display")
      ->check(hpcgi::positive_finite())->capture_default_str();
  cmd->add_option("--snapshots", a.snapshots, "render the scene after these iterations (report Figure 4.2: 1,2,4,8,32)")
      ->delimiter(',')->check(CLI::PositiveNumber);
  cmd->add_option("--snapshot-prefix", a.snapshot_prefix, "snapshot files are PREFIX_iterK.png (default: snapshot)");
  cmd->add_flag("!--no-verify", a.verify, "skip the check against the float64 reference");
  cmd->callback([&a, layout, fused, distribution, overlap] {
    // An option of one backend given with another is refused, not ignored: the record would claim it.
    for (const auto& [opt, backend] : {std::pair{fused, "cublas"}, {distribution, "hybrid"}, {overlap, "hybrid"}})
      if (opt->count() > 0 && a.cfg.backend != backend)
        throw CLI::ValidationError(opt->get_name() + " applies to --backend " + backend + ", not " + a.cfg.backend);
    if (layout->count() == 0)
      for (const auto& b : solve_backends())
        if (b.name == a.cfg.backend && b.layouts.size() == 1) a.cfg.layout = b.layouts.front();
  });
}

int run_solve(const SolveArgs& a) {
  hpcgi::Timer total;
  SolveConfig cfg = a.cfg;
  cfg.threads = a.threads;
  const auto [width, height] = parse_size(a.size);
  double load_s = 0;
  const Mesh m = load_scene(a, &load_s);
  const double n = static_cast<double>(m.size());
  hpcgi::require_host_memory("the form factors of " + std::to_string(m.size()) + " patches", 4.0 * n * n);
  hpcgi::Timer t;
  const FormFactors ff = load_form_factors(a.ff, m);
  const double ff_load_s = t.seconds();
  const System sys = make_system(m, ff.values.data());
  const Camera cam = parse_view(a.view, m);
  RenderOptions ropt;
  ropt.exposure = a.exposure;

  const std::set<long> snaps(a.snapshots.begin(), a.snapshots.end());
  const std::string prefix = a.snapshot_prefix.empty() ? "snapshot" : a.snapshot_prefix;
  std::vector<std::string> snapshot_files;
  IterationCallback cb;
  if (!snaps.empty())
    cb = [&](long it, const std::vector<Rgb>& B) {
      if (!snaps.count(it)) return;
      const std::string f = prefix + "_iter" + std::to_string(it) + ".png";
      write_png(f, render(m, B, cam, width, height, ropt));
      snapshot_files.push_back(f);
    };
  const SolveResult res = solve(sys, cfg, cb);
  const bool failed = res.status == SolveStatus::breakdown || res.status == SolveStatus::nonfinite ||
                      res.status == SolveStatus::divergent;
  Verification v;
  if (a.verify && !failed) v = verify(sys, cfg, res);

  const double passes_bytes = res.matrix_bytes * static_cast<double>(res.matrix_passes);
  const bool gpu = !res.backend_info.empty();  // the GPU backends describe their GPU
  const bool hybrid = cfg.backend == "hybrid";
  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "solve"},
                   {"scene", a.scene},
                   {"patches", m.size()},
                   {"divide", a.load.divide},
                   {"method", cfg.method},
                   {"layout", cfg.layout},
                   {"backend", cfg.backend},
                   {"precision", cfg.precision},
                   {"steps", cfg.steps},
                   {"tol", cfg.steps > 0 ? nlohmann::json() : nlohmann::json(cfg.tol)},
                   {"max_iter", cfg.max_iter},
                   {"threads", res.threads},
                   {"hemicube", ff.params.resolution},
                   {"weights", to_string(ff.params.weights)},
                   {"ff_threshold", ff.params.threshold},
                   {"ff_file", a.ff},
                   {"fused", cfg.backend == "cublas" ? nlohmann::json(cfg.fused) : nlohmann::json()},
                   {"distribution", hybrid ? nlohmann::json(cfg.distribution) : nlohmann::json()},
                   {"overlap", hybrid ? nlohmann::json(cfg.overlap) : nlohmann::json()}};
  rec["result"] = {{"status", to_string(res.status)},
                   {"converged", res.status == SolveStatus::converged},
                   {"iterations", res.iterations},
                   {"rel_residual", res.rel_residual},
                   {"max_rel_residual", *std::max_element(res.rel_residual.begin(), res.rel_residual.end())},
                   {"mesh_hash", mesh_hash(m)}};
  if (!res.detail.empty()) rec["result"]["detail"] = res.detail;
  if (a.verify && !failed)
    rec["verify"] = {{"reference", "float64, openmp backend (bit-identical to serial), aos"},
                     {"reference_iterations", v.reference_iterations},
                     {"max_rel_diff", v.max_rel_diff},
                     {"bound", v.bound},
                     {"agreed", v.agreed}};
  else
    rec["verify"] = {{"agreed", nullptr}};
  const double per_it = res.iterations > 0 ? res.solve_s / static_cast<double>(res.iterations) : 0.0;
  rec["times_s"] = {{"load", load_s},   {"ff_load", ff_load_s}, {"setup", res.setup_s},   {"solve", res.solve_s},
                    {"per_iteration", per_it}, {"check", res.check_s}, {"verify", v.seconds}, {"total", total.seconds()}};
  if (gpu) {
    rec["times_s"]["upload"] = res.upload_s;
    rec["times_s"]["transfer"] = res.transfer_s;
    rec["times_s"]["device_compute"] = res.device_compute_s;
    rec["times_s"]["host_compute"] = res.host_compute_s;
  }
  rec["perf"] = {{"matrix_bytes", res.matrix_bytes},
                 {"matrix_passes", res.matrix_passes},
                 {"bandwidth_GBps", res.solve_s > 0 ? passes_bytes / res.solve_s / 1e9 : 0.0},
                 {"timer", gpu ? "host wall clock, device synchronised; upload, transfer and device_compute by CUDA "
                                 "events, host_compute by the host's clock"
                               : "host wall clock"}};
  if (gpu) rec["perf"]["transfer_bytes"] = res.transfer_bytes;
  nlohmann::json info = {{"threads", std::to_string(res.threads)}};
  for (const auto& [key, value] : res.backend_info) info[key] = value;
  rec["backend_info"] = info;

  if (!a.quiet) {
    std::printf("solve: %s, %zu patches, %s %s %s %s, %d threads\n", a.scene.c_str(), m.size(), cfg.method.c_str(),
                cfg.layout.c_str(), cfg.backend.c_str(), cfg.precision.c_str(), res.threads);
    std::printf("  status %s after %ld iterations: relative residual r %.3e g %.3e b %.3e\n", to_string(res.status),
                res.iterations, res.rel_residual[0], res.rel_residual[1], res.rel_residual[2]);
    if (!res.detail.empty()) std::printf("  %s\n", res.detail.c_str());
    if (a.verify && !failed)
      std::printf("  float64 reference: max relative difference %.3e (bound %.1e): %s\n", v.max_rel_diff, v.bound,
                  v.agreed ? "agreed" : "DISAGREED");
    std::printf("  time: load %.3f s, form factors %.3f s, setup %.4f s, solve %.4f s (%.4g ms/iteration, %.2f GB/s)\n",
                load_s, ff_load_s, res.setup_s, res.solve_s, per_it * 1e3,
                res.solve_s > 0 ? passes_bytes / res.solve_s / 1e9 : 0.0);
    if (gpu)
      std::printf("  device: %s; upload of F %.4f s; during the solve: transfers %.4f s (%.3g MB), device compute "
                  "%.4f s, host compute %.4f s\n",
                  res.backend_info.count("gpu") ? res.backend_info.at("gpu").c_str() : "?", res.upload_s,
                  res.transfer_s, res.transfer_bytes / 1e6, res.device_compute_s, res.host_compute_s);
  }
  // A failed solve's radiosity (NaN, Inf or blown up) is no scene and no picture: only its record is written.
  if (!failed && !a.output_xml.empty()) write_rrv_xml(a.output_xml, m, res.B);
  if (!failed && !a.png.empty()) write_png(a.png, render(m, res.B, cam, width, height, ropt));
  if (!a.quiet)
    for (const auto& f : snapshot_files) std::printf("  snapshot %s\n", f.c_str());
  if (a.json) std::cout << rec.dump() << std::endl;
  if (!a.record_path.empty()) hpcgi::record::append(a.record_path, rec);
  if (failed) throw hpcgi::NumericalError(std::string(to_string(res.status)) + ": " + res.detail);
  return 0;
}

}  // namespace radiosity::app
