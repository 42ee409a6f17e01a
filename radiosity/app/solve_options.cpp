// The options of `bin/radiosity solve` (CLI11), in groups, and the checks that depend on which options were given.
#include "common/cli.hpp"
#include "common/errors.hpp"
#include "radiosity/app/commands.hpp"

namespace radiosity::app {
namespace {

std::string backend_list() {
  std::string s;
  for (const auto& b : solve_backends()) s += (s.empty() ? "" : " | ") + b.name;
  return s;
}

// The options given, whose combinations the callback checks.
struct GivenOptions {
  CLI::Option *layout, *fused, *distribution, *overlap, *stop;
};

// The method and when it stops.
void add_method_options(CLI::App* cmd, SolveArgs& a, GivenOptions& g) {
  add_choice(cmd, "--method", a.cfg.method, parse_method,
             "jacobi | bicgstab | gauss-seidel (sweeps in patch order; openmp: each thread its block of rows, "
             "Jacobi between blocks) | sor (gauss-seidel relaxed by --omega)");
  cmd->add_option("--omega", a.cfg.omega, "sor: the relaxation factor W in (0, 2) (1: gauss-seidel)")
      ->capture_default_str();
  std::string rules;
  for (const std::string& r : stop_rule_bases()) rules += (rules.empty() ? "" : " | ") + r;
  // Parsed once here; an unknown rule is a parse error of CLI11's (one line, exit status 2) like any other.
  const auto stop = [&a](const std::string& s) {
    try {
      a.cfg.stop = parse_stop_rule(s);
    } catch (const hpcgi::UsageError& e) {
      throw CLI::ValidationError("--stop", e.what());
    }
  };
  g.stop = cmd->add_option_function<std::string>(
                  "--stop", stop,
                  "stopping rule with --tol: " + rules + " (residual: ||e - A b|| over ||e||, ||r0||, ||b||; step: "
                  "||b_k - b_k-1|| over ||b_k||, 2- or inf-norm), each +stacked (the channels as one vector, not the "
                  "largest channel) and/or +squared (the value squared)")
               ->default_str(to_string(a.cfg.stop));
  add_choice(cmd, "--start", a.cfg.start, parse_start, "b_0: rrv (max(radiosity, emission), RRV's) | zero | emission");
  cmd->add_flag("--history", a.cfg.history,
                "record every iterate's residuals and steps (result.history; O(n) per iteration)");
  cmd->add_option("--read-sweeps", a.cfg.read_sweeps,
                  "after the method, K read-only sweeps over the arrays of F a product reads, on the same threads "
                  "(times_s.read_sweep_*, perf.read_sweep_GBps: the product's byte limit; serial, openmp)")
      ->check(hpcgi::integer_in(0, 100000))->capture_default_str();
  auto* steps = cmd->add_option("--steps", a.cfg.steps, "exactly K Jacobi (Gauss-Seidel, SOR) steps (RRV: 32), no tolerance")
                    ->check(hpcgi::integer_in(1, 1LL << 40));
  cmd->add_option("--tol", a.cfg.tol, "stop when the stopping rule (--stop; default: every channel's ||e - A b|| / ||e||) is <= tol")
      ->capture_default_str()->excludes(steps);
  cmd->add_option("--max-iter", a.cfg.max_iter, "iteration limit with --tol")->check(hpcgi::integer_in(1, 1LL << 40))
      ->capture_default_str();
}

// Where and in what it runs: layout, backend, precision, the form factors' storage and values, the channels.
void add_machine_options(CLI::App* cmd, SolveArgs& a, GivenOptions& g) {
  g.layout = add_choice(cmd, "--layout", a.cfg.layout, parse_layout,
                        "aos (one r,g,b record per patch) | soa (one array per channel); default: aos, or the one "
                        "layout a backend runs (cublas: soa)");
  cmd->add_option("--backend", a.cfg.backend, backend_list())->capture_default_str();
  add_choice(cmd, "--precision", a.cfg.precision, parse_precision, "working precision of B and of the sums: float | double");
  cmd->add_option("--storage", a.storage,
                  "form factors held as auto (of those the backend reads, the one that moves the fewest bytes per "
                  "step) | dense (n x n) | csr (only the kept F_ij: values and int32 columns) | compressed (csr with "
                  "uint16 column steps) | runs (runs of consecutive columns: values and 4 bytes a run)")
      ->check(CLI::IsMember({"auto", "dense", "csr", "compressed", "runs"}))->capture_default_str();
  cmd->add_option("--ff-precision", a.ff_precision,
                  "form factors stored as float32 | float16 (scaled by a power of two) | bfloat16, widened to the "
                  "working precision in the sums (16 bits: serial and openmp)")
      ->check(CLI::IsMember({"float32", "float16", "bfloat16"}))->capture_default_str();
  cmd->add_option("--threshold", a.threshold, "drop the form factors with |F_ij| <= T when loading them")
      ->check(hpcgi::fraction_below_one())->capture_default_str();
  add_choice(cmd, "--channels", a.cfg.channels, parse_channels,
             "auto (a grey scene, r = g = b everywhere, is solved as one channel on serial and openmp) | 3");
}

// The error reference.
void add_reference_options(CLI::App* cmd, SolveArgs& a) {
  cmd->add_option("--reference-ff", a.reference_ff,
                  "form factors of the error reference (result.error_vs_reference), e.g. a finer hemicube; "
                  "default: --ff before threshold and rounding");
  cmd->add_option("--reference-divide", a.reference_divide,
                  "the error reference's mesh: the scene at this smaller maximum patch area (its form factors in "
                  "--reference-ff), carried onto this mesh by area-weighted means")
      ->check(hpcgi::positive_finite());
}

// The options of one backend.
void add_gpu_options(CLI::App* cmd, SolveArgs& a, GivenOptions& g) {
  g.fused =
      cmd->add_flag("--fused", a.cfg.fused, "cublas: one cublasSgemm over the three channels, not an Sgemv per channel");
  g.distribution = cmd->add_option("--distribution", a.cfg.distribution,
                                   "hybrid: the share d in [0, 1] of rows on the GPU (the first ceil(d n))")
                       ->capture_default_str();
  g.overlap =
      cmd->add_flag("--overlap", a.cfg.overlap, "hybrid: exchange the halves through pinned memory, overlapping the CPU");
}

// The solved scene, its pictures, and the check.
void add_output_options(CLI::App* cmd, SolveArgs& a) {
  cmd->add_option("--output", a.output_xml, "write the solved scene in RRV's format (RRV's visualizer reads it)");
  cmd->add_option("--png", a.png, "render the solved scene to a PNG");
  cmd->add_option("--view", a.view, "camera: auto | front | top | inside | ex,ey,ez:tx,ty,tz[:fov]")
      ->capture_default_str();
  cmd->add_option("--size", a.size, "picture size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--exposure", a.exposure, "multiply radiosity by E before display")
      ->check(hpcgi::positive_finite())->capture_default_str();
  cmd->add_option("--snapshots", a.snapshots, "render the scene after these iterations (report Figure 4.2: 1,2,4,8,32)")
      ->delimiter(',')->check(hpcgi::integer_in(1, 1LL << 40));
  cmd->add_option("--snapshot-prefix", a.snapshot_prefix, "snapshot files are PREFIX_iterK.png (default: snapshot)");
  cmd->add_flag("!--no-verify", a.verify, "skip the check against the float64 reference and the error reference");
}

// The rules on which options were given (CLI11 sees what was given; the plan, solve_plan.cpp, and the library's
// check_config see the values).
void check_given(SolveArgs& a, const GivenOptions& g) {
  if (g.stop->count() > 0 && a.cfg.steps > 0)
    throw CLI::ValidationError("--stop is a rule for --tol; --steps runs a fixed number of steps");
  if (a.min_time > 0 && !a.snapshots.empty())
    throw CLI::ValidationError("--min-time repeats the solve, and --snapshots would draw every repetition's: time the "
                               "solve without snapshots");
  if (a.reference_divide > 0 && a.reference_ff.empty())
    throw CLI::ValidationError("--reference-divide needs --reference-ff, the form factors of that mesh");
  // An option of some backends given with another is refused, not ignored: the record would claim it. The registry
  // says which take it (an unknown backend is the plan's to refuse).
  const SolveBackend* backend = find_backend(a.cfg.backend);
  if (!backend) return;
  for (const auto& [opt, fact] : {std::pair{g.fused, &SolveBackend::fuses},
                                  {g.distribution, &SolveBackend::splits_rows}, {g.overlap, &SolveBackend::splits_rows}})
    if (opt->count() > 0 && !(backend->*fact)) {
      std::string takers;
      for (const SolveBackend& b : solve_backends())
        if (b.*fact) takers += (takers.empty() ? "" : " or ") + b.name;
      throw CLI::ValidationError(opt->get_name() + " applies to --backend " + takers + ", not " + a.cfg.backend);
    }
  if (g.layout->count() == 0 && backend->layouts.size() == 1) a.cfg.layout = backend->layouts.front();
}

}  // namespace

void add_solve(CLI::App& app, SolveArgs& a) {
  CLI::App* cmd = app.add_subcommand("solve", "solve for the radiosity of a scene whose form factors are in a file");
  cmd->footer(hpcgi::exit_status_help("--no-verify"));
  add_scene_options(cmd, a);
  add_memory_option(cmd, a);
  cmd->add_option("--ff", a.ff, "form-factor file written by `bin/radiosity formfactors` for this scene")
      ->required();
  GivenOptions g{};
  add_method_options(cmd, a, g);
  add_machine_options(cmd, a, g);
  add_reference_options(cmd, a);
  add_gpu_options(cmd, a, g);
  add_output_options(cmd, a);
  hpcgi::add_min_time_option(cmd, a.min_time);
  cmd->callback([&a, g] { check_given(a, g); });
}

}  // namespace radiosity::app
