// `bin/radiosity relight`: frames of new light settings and reflectivities over fixed form factors (issue 20).
// Frames that change only lights are mixed from the light basis (radiosity/relight/basis.hpp); frames that change a
// reflectivity are solved, warm-started from the previous frame's B. Per frame: time, iterations, residual and,
// every --check-every K frames, the error against a cold float64 solve of that frame.
// --bench-rhs K times the backend's product with K right-hand sides instead (make bench; the driver's
// bench_multi_product).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

#include "common/cli.hpp"
#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/app/relight_phases.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/relight/basis_file.hpp"
#include "radiosity/relight/frames.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/solve/multi_solve.hpp"

namespace radiosity::app {
namespace {

using namespace radiosity::relight;

// The product with k right-hand sides, timed (make bench): passes products after one untimed warm-up, through the
// driver (bench_multi_product) on the frames' F and the backend's k-product in float.
int bench_product(const RelightArgs& a, const Mesh& m, const FFMatrixView& view, double bytes, nlohmann::json& rec) {
  const size_t n = m.size(), k = size_t(a.bench_rhs);
  const System sys = make_system(m, view);
  std::vector<std::vector<Rgb>> X(k, std::vector<Rgb>(n));
  for (size_t q = 0; q < k; ++q)
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) X[q][i][c] = sys.emission[i][c] + 0.01 * double((i * 7 + q * 13 + c) % 101);
  SolveConfig cfg;
  cfg.backend = a.cfg.backend;
  cfg.precision = Precision::single;
  cfg.threads = a.threads;
  const MultiBench b = bench_multi_product(sys, X, cfg, a.passes);
  auto fact = [&](const char* name) {
    for (const auto& [key, value] : b.facts)
      if (key == name) return value;
    return 0.0;
  };
  const double med = percentile(b.product_ms, 50), k1 = percentile(b.k1_ms, 50), single = percentile(b.single_ms, 50);
  const double blocks = fact("blocks_bytes"), build_ms = fact("blocks_build_ms"), read = blocks > 0 ? blocks : bytes;
  rec["result"] = {{"rhs", k},
                   {"product_ms_median", med},
                   {"product_ms", b.product_ms},
                   {"per_rhs_ms", med / double(k)},
                   {"single_product_ms_median", single},
                   {"k1_product_ms_median", k1},
                   {"over_k1_alternating", med / k1},
                   {"matrix_bytes", bytes},
                   {"blocks_bytes", blocks},
                   {"blocks_fill", fact("blocks_fill")},
                   {"blocks_build_ms", build_ms},
                   {"bandwidth_GBps", read / (med * 1e-3) / 1e9},  // of what the product reads
                   {"threads", b.threads}};
  if (!a.quiet)
    std::printf("relight --bench-rhs %zu: %s %s F of %zu patches (%.1f MB; row blocks %.1f MB, built in %.0f ms), %d "
                "threads: product %.3f ms (median of %ld), %.3f ms per right-hand side, %.2f GB/s read; k = 1 in turns "
                "with it %.3f ms (ratio %.2f); one-right-hand-side solver product %.3f ms\n",
                k, to_string(view.storage), to_string(view.values), n, bytes / 1e6, blocks / 1e6, build_ms, b.threads,
                med, a.passes, med / double(k), read / (med * 1e-3) / 1e9, k1, med / k1, single);
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
                     ->check(CLI::Range(size_t(1), kMaxFrames))->excludes(frames);
  cmd->add_option("--seed", a.seed, "seed of --random-frames")->capture_default_str();
  cmd->add_option("--basis", a.basis,
                  "light-basis file: read when it exists (it must belong to this mesh, form factors and colours), "
                  "else solved and written there");
  cmd->add_option("--basis-tol", a.basis_tol, "relative residual every light's solve reaches (Jacobi, float64)")
      ->check(hpcgi::positive_finite())->capture_default_str();
  add_choice(cmd, "--method", a.cfg.method, parse_method, "reflectivity frames: jacobi | bicgstab",
             {Method::jacobi, Method::bicgstab});
  cmd->add_option("--backend", a.cfg.backend,
                  "the light basis's k-right-hand-side solve and the reflectivity frames: serial | openmp | mpi (the "
                  "basis on MPI ranks under mpirun; frames of lights only)")
      ->capture_default_str();
  add_choice(cmd, "--precision", a.cfg.precision, parse_precision, "reflectivity frames: float | double");
  cmd->add_option("--ff-precision", a.ff_precision, "reflectivity frames: F stored as float32 | float16 | bfloat16")
      ->check(CLI::IsMember({"float32", "float16", "bfloat16"}))->capture_default_str();
  cmd->add_option("--storage", a.storage,
                  "F held as auto (of those the frames' backend reads, the one with the fewest bytes per product, "
                  "sparse below half of dense's) | dense | csr | compressed | runs: the light basis, the reflectivity "
                  "frames and --bench-rhs read it")
      ->check(CLI::IsMember({"auto", "dense", "csr", "compressed", "runs"}))->capture_default_str();
  a.cfg.tol = 1e-4;
  cmd->add_option("--tol", a.cfg.tol, "reflectivity frames: stop at this relative residual")->capture_default_str();
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
  // Under mpirun (--backend mpi) every rank plans and loads the same: a refusal is agreed, and rank 0 reports it.
  const RelightPlan p = hpcgi::comm::agreed([&] { return plan_relight(a); });
  RelightInputs in;
  hpcgi::comm::agreed([&] { load_relight(a, p, in); });
  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "relight"},       {"scene", a.scene},
                   {"patches", in.m.size()},     {"divide", a.load.divide},
                   {"ff_file", a.ff},            {"hemicube", in.ff_file.info().params.resolution},
                   {"weights", to_string(in.ff_file.info().params.weights)},
                   {"ff_precision", a.ff_precision},
                   {"storage", to_string(in.storage)},
                   {"storage_requested", a.storage}};
  if (a.bench_rhs > 0) {
    rec["params"]["bench_rhs"] = a.bench_rhs;
    rec["params"]["passes"] = a.passes;
    if (!a.quiet) std::printf("relight: form factors %s\n", storage_words(p, in).c_str());
    bench_product(a, in.m, in.frame_view, in.frame_bytes, rec);
    rec["times_s"] = {{"load", in.load_s}, {"ff_load", in.ff_load_s}, {"ff_build", in.ff_build_s},
                      {"total", total.seconds()}};
    hpcgi::record::emit(rec, a);
    return 0;
  }
  BasisOptions bopt;
  bopt.tol = a.basis_tol;
  bopt.threads = a.threads;
  bopt.backend = a.cfg.backend;
  bool loaded = false;
  const LightBasis basis = load_or_solve_basis(a.basis, in.m, in.ff_file, in.basis_view, in.lights, bopt, &loaded);
  // Backend mpi: the ranks solved the basis together; rank 0 alone serves the frames (from the basis: no solve)
  // and writes the record.
  if (!hpcgi::comm::root()) return 0;
  const ServedFrames served = serve_frames(a, p, in, basis);
  relight_record(rec, a, in, basis, loaded, served, total.seconds());
  if (!a.quiet) print_relight_summary(a, p, in, basis, loaded, served);
  hpcgi::record::set_outcome(rec, served.outcome);
  hpcgi::record::emit(rec, a);
  hpcgi::finish(served.outcome);
  return 0;
}

}  // namespace radiosity::app
