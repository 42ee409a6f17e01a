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
#include <optional>

#include "common/cli.hpp"
#include "common/errors.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/app/relight_phases.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/relight/basis_file.hpp"
#include "radiosity/relight/frames.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/solve/host/exec.hpp"
#include "radiosity/solve/host/linalg.hpp"

namespace radiosity::app {
namespace {

using namespace radiosity::relight;

// The product with k right-hand sides, timed (make bench): passes products after one untimed warm-up.
int bench_product(const RelightArgs& a, const Mesh& m, const FFMatrixView& view, double bytes, nlohmann::json& rec) {
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
  // k >= 2: the product over F's row blocks (built here, timed apart), as the light basis runs it; k = 1: the
  // solvers' product over F as stored, as the basis of one light runs it.
  hpcgi::Timer build;
  std::optional<RowBlockMatrix> blocks;
  if (k > 1) blocks.emplace(view, rows, ex.threads());
  const double build_ms = build.seconds() * 1e3;
  auto one = [&](std::vector<Soa<float>>& x, std::vector<Soa<float>>& y, std::vector<Soa<float>>& ee) {
    affine_matvec(ex, view, rows, x[0], y[0], rho, ee[0], 0.0f, 1.0f, 1.0f);
  };
  // The k-product and the product with k = 1 in turns, pass by pass, so that their ratio compares passes that ran
  // under the same load (this project's VM is shared); pass 0 warms the caches and the threads.
  std::vector<double> ms, one_ms;
  for (long p = 0; p <= a.passes; ++p) {
    hpcgi::Timer t;
    if (blocks)
      multi_affine_matvec<OpenMPExec, float>(ex, *blocks, X, Y, rho, E, 0.0f, 1.0f, 1.0f);
    else
      one(X, Y, E);
    const double tk = t.seconds() * 1e3;
    t.reset();
    one(X1, Y1, E1);
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
  const double med = percentile(ms, 50), read = blocks ? blocks->bytes() : bytes;
  rec["result"] = {{"rhs", k},
                   {"product_ms_median", med},
                   {"product_ms", ms},
                   {"per_rhs_ms", med / double(k)},
                   {"single_product_ms_median", percentile(single_ms, 50)},
                   {"k1_product_ms_median", percentile(one_ms, 50)},
                   {"over_k1_alternating", med / percentile(one_ms, 50)},
                   {"matrix_bytes", bytes},
                   {"blocks_bytes", blocks ? blocks->bytes() : 0.0},
                   {"blocks_fill", blocks ? double(blocks->nonzeros()) / double(blocks->columns() * kBlockRows) : 0.0},
                   {"blocks_build_ms", blocks ? build_ms : 0.0},
                   {"bandwidth_GBps", read / (med * 1e-3) / 1e9},  // of what the product reads
                   {"threads", ex.threads()}};
  if (!a.quiet)
    std::printf("relight --bench-rhs %zu: %s %s F of %zu patches (%.1f MB; row blocks %.1f MB, built in %.0f ms), %d "
                "threads: product %.3f ms (median of %ld), %.3f ms per right-hand side, %.2f GB/s read; k = 1 in turns "
                "with it %.3f ms (ratio %.2f); one-right-hand-side solver product %.3f ms\n",
                k, to_string(view.storage), to_string(view.values), n, bytes / 1e6, blocks ? blocks->bytes() / 1e6 : 0.0,
                build_ms, ex.threads(), med, a.passes, med / double(k), read / (med * 1e-3) / 1e9,
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
                     ->check(CLI::Range(size_t(1), kMaxFrames))->excludes(frames);
  cmd->add_option("--seed", a.seed, "seed of --random-frames")->capture_default_str();
  cmd->add_option("--basis", a.basis,
                  "light-basis file: read when it exists (it must belong to this mesh, form factors and colours), "
                  "else solved and written there");
  cmd->add_option("--basis-tol", a.basis_tol, "relative residual every light's solve reaches (Jacobi, float64)")
      ->check(hpcgi::positive_finite())->capture_default_str();
  add_choice(cmd, "--method", a.cfg.method, parse_method, "reflectivity frames: jacobi | bicgstab",
             {Method::jacobi, Method::bicgstab});
  cmd->add_option("--backend", a.cfg.backend, "reflectivity frames: a backend of `solve`")->capture_default_str();
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
  const RelightPlan p = plan_relight(a);
  RelightInputs in;
  load_relight(a, p, in);
  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "relight"},       {"scene", a.scene},
                   {"patches", in.m.size()},     {"divide", a.load.divide},
                   {"ff_file", a.ff},            {"hemicube", in.ff.params.resolution},
                   {"weights", to_string(in.ff.params.weights)},
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
  bool loaded = false;
  const LightBasis basis = load_or_solve_basis(a.basis, in.m, a.ff, in.basis_view, in.lights, bopt, &loaded);
  const ServedFrames served = serve_frames(a, p, in, basis);
  relight_record(rec, a, in, basis, loaded, served, total.seconds());
  if (!a.quiet) print_relight_summary(a, p, in, basis, loaded, served);
  hpcgi::record::set_outcome(rec, served.outcome);
  hpcgi::record::emit(rec, a);
  hpcgi::finish(served.outcome);
  return 0;
}

}  // namespace radiosity::app
