// `bin/radiosity solve`: one solve of a scene whose form factors are in a file, checked against the float64
// reference, with the scene, pictures and a record written on request.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <set>

#include "common/cli.hpp"
#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/app/distributed.hpp"
#include "radiosity/app/reference.hpp"
#include "radiosity/dist/split.hpp"
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/render/png_writer.hpp"
#include "radiosity/render/render.hpp"
#include "radiosity/scene/rrv_writer.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/mesh_map.hpp"
#include "radiosity/solve/storage/ff_matrix_file.hpp"
#include "radiosity/solve/storage/storage_choice.hpp"
#ifdef HAVE_MPI
#include "radiosity/dist/ff_mpi.hpp"
#endif

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

// The agreement check of a run (BabelStream's check_solution): the same method on the run's own system, the form
// factors as the run stored them (threshold, 16-bit values, storage), in float64, AOS, backend openmp (which agrees
// bit for bit with serial), three channels: a fixed-step run against the same steps, where only rounding may
// differ; a run that stops on a tolerance against the converged solution, from which it may differ by about tol
// times the condition number of I - diag(ρ)F, at most (1 + ρ)/(1 - ρ) ≈ 19 for ρ ≤ 0.9. `converged` is that
// solution when the caller has it already (null: computed here).
struct Verification {
  double max_rel_diff = 0, bound = 0, seconds = 0;
  long reference_iterations = 0;
  bool agreed = false;
};
Verification verify(const System& sys, const SolveConfig& cfg, const SolveResult& res, const ErrorReference* converged) {
  hpcgi::Timer t;
  Verification v;
  std::vector<Rgb> R;
  if (cfg.steps > 0) {
    SolveConfig ref = cfg;
    ref.backend = holds_all_rows(sys) ? "openmp" : "mpi";  // an MPI rank's system: the same ranks check it
    ref.layout = "aos";
    ref.precision = "double";
    ref.channels = "3";
    ref.ff_threshold = 0;
    ref.fused = ref.overlap = false;
    if (cfg.backend == "original") ref.method = "jacobi";
    if (cfg.backend == "serial") ref.threads = 1;  // gauss-seidel and sor: the same one block of rows
    ref.history = false;
    SolveResult r = solve(sys, ref);
    v.reference_iterations = r.iterations;
    R = std::move(r.B);
  } else {
    const ErrorReference own = converged ? ErrorReference{} : converged_reference(sys, "the run's form factors");
    if (!converged) converged = &own;
    v.reference_iterations = converged->iterations;
    R = converged->B;
  }
  v.max_rel_diff = max_rel_diff(res.B, R);
  v.bound = cfg.steps > 0 ? (cfg.precision == "double" ? 1e-10 : 1e-5) : 1e-5 + 20 * cfg.tol;
  v.agreed = v.max_rel_diff <= v.bound;
  v.seconds = t.seconds();
  return v;
}

// The exit status of a solve (common/errors.hpp): 3 its numbers went wrong, 4 it stopped at --max-iter, 5 its
// float64 check (v: null when not made) disagreed, else 0.
hpcgi::Outcome outcome_of(const SolveResult& res, const SolveConfig& cfg, const Verification* v) {
  char why[256];
  if (failed(res.status))  // a stagnant run's detail says it all ("no solution: ...")
    return {hpcgi::kExitNumerical,
            res.status == SolveStatus::stagnant ? res.detail : std::string(to_string(res.status)) + ": " + res.detail};
  if (res.status == SolveStatus::max_iter) {
    std::snprintf(why, sizeof why, "%s stopped at --max-iter %ld with the largest relative residual %.3e, above --tol %.1e",
                  cfg.method.c_str(), cfg.max_iter,
                  *std::max_element(res.rel_residual.begin(), res.rel_residual.end()), cfg.tol);
    return {hpcgi::kExitNotConverged, why};
  }
  if (v && !v->agreed) {
    std::snprintf(why, sizeof why, "max relative difference %.3e from the float64 reference, above the bound %.1e",
                  v->max_rel_diff, v->bound);
    return {hpcgi::kExitDisagreed, why};
  }
  return {};
}

// A sparse form-factor file is solved as it is stored: by a backend that reads any storage, in its own storage and
// values, at its own threshold.
void check_sparse_file_request(const SolveArgs& a, const SolveBackend& b, const FormFactorFileInfo& info) {
  const std::string file = "--ff '" + a.ff + "' holds " + info.storage + " " + info.precision + " form factors";
  if (!b.any_storage)
    throw hpcgi::UsageError(file + ": backend '" + b.name + "' reads dense float32 files only (write the file with "
                            "formfactors --storage dense)");
  if (a.storage != "auto" && a.storage != info.storage)
    throw hpcgi::UsageError(file + ", not " + a.storage + ": give --storage auto or " + info.storage);
  if (a.ff_precision != info.precision)
    throw hpcgi::UsageError(file + ": give --ff-precision " + info.precision + " (the values are read as stored)");
  if (a.threshold > 0)
    throw hpcgi::UsageError(file + ": --threshold applies when a dense file is loaded (this file's threshold is " +
                            std::to_string(info.params.threshold) + ")");
}

const SolveBackend& find_backend(const std::string& name) {
  for (const auto& b : solve_backends())
    if (b.name == name) return b;
  throw hpcgi::UsageError("unknown solver backend '" + name + "' (known: " + backend_list() + ")");
}

std::string gib(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f GiB", bytes / (1 << 30));
  return buf;
}

// Vectors of a solve and of its float64 references beside it: at most BiCG-STAB's 7 slots plus ρ and E, in
// double, three channels, twice, and the host's copies of B (a few per run).
double vector_bytes(size_t n) { return (2 * (8 + 2) * 3 * 8 + 8 * 3 * 8) * double(n); }

// The history of a run (--history): per iterate k = 0, 1, ... its norms as the method measured them (res2, step2,
// b2: squares of 2-norms per channel; step_inf, b_inf: ∞-norms; null where not known), from which
// analysis/table42_audit.py replays any stopping rule, the run's rule value, and the relative measures
// ‖e - A b‖₂/‖e‖₂, ‖Δb‖₂/‖b‖₂, ‖Δb‖∞/‖b‖∞ per channel (rel_*) and over the stacked channels (rel_*_stacked).
nlohmann::json history_json(const SolveResult& res, const SolveConfig& cfg) {
  nlohmann::json h = {{"rule", cfg.stop}, {"e2", res.e2}, {"r0_2", res.r0_2}};
  const StopRule rule = parse_stop_rule(cfg.stop);
  const StopRule measures[] = {parse_stop_rule("residual-e"), parse_stop_rule("residual-e+stacked"),
                               parse_stop_rule("step-2"), parse_stop_rule("step-2+stacked"),
                               parse_stop_rule("step-inf"), parse_stop_rule("step-inf+stacked")};
  const char* names[] = {"rel_residual_e", "rel_residual_e_stacked", "rel_step_2", "rel_step_2_stacked",
                         "rel_step_inf", "rel_step_inf_stacked"};
  for (const char* key : {"iteration", "res2", "step2", "step_inf", "b2", "b_inf", "rule_value", names[0], names[1],
                          names[2], names[3], names[4], names[5]})
    h[key] = nlohmann::json::array();
  for (const IterateNorms& k : res.history) {
    h["iteration"].push_back(k.iteration);
    h["res2"].push_back(k.res2);
    h["step2"].push_back(k.step2);
    h["step_inf"].push_back(k.step_inf);
    h["b2"].push_back(k.b2);
    h["b_inf"].push_back(k.b_inf);
    h["rule_value"].push_back(rule.value(k, res.e2, res.r0_2));
    for (int m = 0; m < 6; ++m) {
      const Rgb v = measures[m].values(k, res.e2, res.r0_2);
      if (m % 2)
        h[names[m]].push_back(v[0]);
      else
        h[names[m]].push_back(v);
    }
  }
  return h;
}

}  // namespace

void add_solve(CLI::App& app, SolveArgs& a) {
  CLI::App* cmd = app.add_subcommand("solve", "solve for the radiosity of a scene whose form factors are in a file");
  cmd->footer(hpcgi::exit_status_help());
  add_scene_options(cmd, a);
  add_memory_option(cmd, a);
  cmd->add_option("--ff", a.ff, "form-factor file written by `bin/radiosity formfactors` for this scene")
      ->required();
  cmd->add_option("--method", a.cfg.method,
                  "jacobi | bicgstab | gauss-seidel (sweeps in patch order; openmp: each thread its block of rows, "
                  "Jacobi between blocks) | sor (gauss-seidel relaxed by --omega)")
      ->check(CLI::IsMember({"jacobi", "bicgstab", "gauss-seidel", "sor"}))->capture_default_str();
  CLI::Option* omega =
      cmd->add_option("--omega", a.cfg.omega, "sor: the relaxation factor W in (0, 2) (1: gauss-seidel)")
          ->capture_default_str();
  std::string rules;
  for (const std::string& r : stop_rule_bases()) rules += (rules.empty() ? "" : " | ") + r;
  CLI::Option* stop = cmd->add_option("--stop", a.cfg.stop,
                  "stopping rule with --tol: " + rules + " (residual: ||e - A b|| over ||e||, ||r0||, ||b||; step: "
                  "||b_k - b_k-1|| over ||b_k||, 2- or inf-norm), each +stacked (the channels as one vector, not the "
                  "largest channel) and/or +squared (the value squared)")
      ->capture_default_str();
  cmd->add_option("--start", a.cfg.start, "b_0: rrv (max(radiosity, emission), RRV's) | zero | emission")
      ->check(CLI::IsMember({"rrv", "zero", "emission"}))->capture_default_str();
  cmd->add_flag("--history", a.cfg.history,
                "record every iterate's residuals and steps (result.history; O(n) per iteration)");
  auto* steps = cmd->add_option("--steps", a.cfg.steps, "exactly K Jacobi (Gauss-Seidel, SOR) steps (RRV: 32), no tolerance")
                    ->check(hpcgi::integer_in(1, 1LL << 40));
  cmd->add_option("--tol", a.cfg.tol, "stop when the stopping rule (--stop; default: every channel's ||e - A b|| / ||e||) is <= tol")
      ->check(hpcgi::positive_finite())->capture_default_str()->excludes(steps);
  cmd->add_option("--max-iter", a.cfg.max_iter, "iteration limit with --tol")->check(hpcgi::integer_in(1, 1LL << 40))
      ->capture_default_str();
  CLI::Option* layout =
      cmd->add_option("--layout", a.cfg.layout,
                      "aos (one r,g,b record per patch) | soa (one array per channel); default: aos, or the one "
                      "layout a backend runs (cublas: soa)")
          ->check(CLI::IsMember({"aos", "soa"}))->capture_default_str();
  cmd->add_option("--backend", a.cfg.backend, backend_list())->capture_default_str();
  cmd->add_option("--precision", a.cfg.precision, "working precision of B and of the sums: float | double")
      ->check(CLI::IsMember({"float", "double"}))->capture_default_str();
  cmd->add_option("--storage", a.storage,
                  "form factors held as auto (of those the backend reads, the one that moves the fewest bytes per "
                  "step) | dense (n x n) | csr (only the kept F_ij: values and int32 columns) | compressed (csr with "
                  "uint16 column steps)")
      ->check(CLI::IsMember({"auto", "dense", "csr", "compressed"}))->capture_default_str();
  cmd->add_option("--ff-precision", a.ff_precision,
                  "form factors stored as float32 | float16 (scaled by a power of two) | bfloat16, widened to the "
                  "working precision in the sums (16 bits: serial and openmp)")
      ->check(CLI::IsMember({"float32", "float16", "bfloat16"}))->capture_default_str();
  cmd->add_option("--threshold", a.threshold, "drop the form factors with |F_ij| <= T when loading them")
      ->check(hpcgi::fraction_below_one())->capture_default_str();
  cmd->add_option("--channels", a.cfg.channels,
                  "auto (a grey scene, r = g = b everywhere, is solved as one channel on serial and openmp) | 3")
      ->check(CLI::IsMember({"auto", "3"}))->capture_default_str();
  cmd->add_option("--reference-ff", a.reference_ff,
                  "form factors of the error reference (result.error_vs_reference), e.g. a finer hemicube; "
                  "default: --ff before threshold and rounding");
  cmd->add_option("--reference-divide", a.reference_divide,
                  "the error reference's mesh: the scene at this smaller maximum patch area (its form factors in "
                  "--reference-ff), carried onto this mesh by area-weighted means")
      ->check(hpcgi::positive_finite());
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
      ->delimiter(',')->check(hpcgi::integer_in(1, 1LL << 40));
  cmd->add_option("--snapshot-prefix", a.snapshot_prefix, "snapshot files are PREFIX_iterK.png (default: snapshot)");
  cmd->add_flag("!--no-verify", a.verify, "skip the check against the float64 reference and the error reference");
  cmd->callback([&a, layout, fused, distribution, overlap, omega, stop] {
    if (omega->count() > 0 && a.cfg.method != "sor")
      throw CLI::ValidationError("--omega applies to --method sor, not " + a.cfg.method);
    if (stop->count() > 0 && a.cfg.steps > 0)
      throw CLI::ValidationError("--stop is a rule for --tol; --steps runs a fixed number of steps");
    if (a.reference_divide > 0 && a.reference_ff.empty())
      throw CLI::ValidationError("--reference-divide needs --reference-ff, the form factors of that mesh");
    // An option of one backend given with another is refused, not ignored: the record would claim it.
    for (const auto& [opt, backend] : {std::pair{fused, "cublas"}, {distribution, "hybrid"}, {overlap, "hybrid"}})
      if (opt->count() > 0 && a.cfg.backend != backend)
        throw CLI::ValidationError(opt->get_name() + " applies to --backend " + backend + ", not " + a.cfg.backend);
    if (layout->count() == 0)
      for (const auto& b : solve_backends())
        if (b.name == a.cfg.backend && b.layouts.size() == 1) a.cfg.layout = b.layouts.front();
  });
}

// The picture of iteration k asked for by --snapshots.
std::string snapshot_file(const SolveArgs& a, long k) {
  return (a.snapshot_prefix.empty() ? std::string("snapshot") : a.snapshot_prefix) + "_iter" + std::to_string(k) + ".png";
}

int run_solve(const SolveArgs& a) {
  hpcgi::Timer total;
  SolveConfig cfg = a.cfg;
  cfg.threads = a.threads;
  // Backend mpi: every rank reads its block of rows of F and the ranks solve together; rank 0 alone prints and
  // writes (the record, the scene, the pictures). Every check before the first collective runs on every rank alike,
  // and the ranks agree on its outcome (comm::agreed), so that rank 0 alone reports a refusal.
  const int ranks = hpcgi::comm::size(), rank = hpcgi::comm::rank();
  const bool root = hpcgi::comm::root();
  std::pair<int, int> picture;
  const SolveBackend* chosen = nullptr;
  FFValues values = FFValues::float32;
  double limit = 0;
  hpcgi::comm::agreed([&] {
    picture = parse_size(a.size);
    chosen = &find_backend(cfg.backend);
    values = parse_ff_values(a.ff_precision);
    limit = a.memory_limit();
    std::vector<hpcgi::files::Output> outputs{{a.output_xml, "--output"}, {a.png, "--png"}};
    const long last = cfg.steps > 0 ? cfg.steps : cfg.max_iter;
    for (long k : a.snapshots) {
      if (k < 1 || k > last)
        throw hpcgi::UsageError("--snapshots " + std::to_string(k) + ": no such iteration (the run has at most " +
                                std::to_string(last) + ")");
      outputs.push_back({snapshot_file(a, k), "--snapshots"});
    }
    check_files(a, outputs, {{a.ff, "--ff"}, {a.reference_ff, "--reference-ff"}});
    if (cfg.steps == 0) hpcgi::check_tolerance(cfg.tol, cfg.precision);
    if (!chosen->built)  // before anything is read for it
      throw hpcgi::UsageError("solver backend '" + chosen->name + "' is not available: " + chosen->why_not);
    if (chosen->distributed && !a.reference_ff.empty())
      throw hpcgi::UsageError("--reference-ff is read by one process; backend mpi takes its error reference from "
                              "--ff (solve the finer mesh with serial or openmp)");
    if (!chosen->any_storage && ((a.storage != "auto" && a.storage != "dense") || values != FFValues::float32))
      throw hpcgi::UsageError("backend '" + chosen->name + "' reads dense float32 form factors only: --storage " +
                              "csr|compressed and --ff-precision float16|bfloat16 run on serial and openmp");
  });
  const auto [width, height] = picture;
  const SolveBackend& backend = *chosen;
  const bool dist = backend.distributed;
  double load_s = 0;
  const Mesh m = hpcgi::comm::agreed([&] {
    Mesh mesh = load_scene(a, &load_s);
    require_rows_for_ranks(mesh.size(), dist ? ranks : 1);
    return mesh;
  });
  const size_t n = m.size();
  const double n2 = double(n) * double(n);
  const std::string patches = std::to_string(n) + " patches";

  // The error reference from other form factors (a finer hemicube or mesh), solved and freed before the run's
  // own form factors are loaded, so that the two never take memory at once.
  ErrorReference ref;
  bool have_ref = false;
  if (a.verify && !a.reference_ff.empty()) {
    Mesh fine;
    if (a.reference_divide > 0) {
      LoadOptions lo = a.load;
      lo.divide = a.reference_divide;
      fine = load_rrv_scene(a.scene, lo);
    }
    const Mesh& rm = a.reference_divide > 0 ? fine : m;
    const double rn = double(rm.size());
    hpcgi::require_host_memory("the error reference on " + std::to_string(rm.size()) + " patches (its dense float32 "
                               "form factors " + gib(4 * rn * rn) + ", vectors " + gib(vector_bytes(rm.size())) + ")",
                               4 * rn * rn + vector_bytes(rm.size()));
    const FormFactors rff = load_form_factors(a.reference_ff, rm);
    ref = converged_reference(make_system(rm, rff.values.data()), "");
    char what[96];
    std::snprintf(what, sizeof what, " (hemicube R=%d, %zu patches, divide %g)", rff.params.resolution, rm.size(),
                  rm.size() == n ? a.load.divide : a.reference_divide);
    ref.of = a.reference_ff + what;
    if (a.reference_divide > 0 && mesh_hash(fine) != mesh_hash(m)) ref.B = area_weighted_onto(m, fine, ref.B);
    have_ref = true;
  }

  // A sparse file (version 2) is read as it is stored, never dense (ff_matrix_file.hpp). Its header says so; what
  // is no file at all is taken for a dense one here (the memory check refuses it from the patch count, the load
  // by what it is).
  const FormFactorFileInfo file_info = hpcgi::comm::agreed([&] {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(a.ff, ec)) return FormFactorFileInfo{};
    FormFactorFileInfo info = check_any_form_factor_file(a.ff, m);
    if (info.version != 1) check_sparse_file_request(a, backend, info);
    return info;
  });
  const bool sparse_file = file_info.version != 1;

  // Memory: the file's dense float32 values (always read whole; on MPI ranks each its block of rows), or a sparse
  // file's matrix, a 16-bit dense copy, the vectors; a CSR copy is checked once its size is known (the kept values
  // are counted after loading). --max-memory-per-rank is checked first, the same on every rank (the split depends
  // on the mesh only).
  const bool dense16 = a.storage == "dense" && values != FFValues::float32;
  const double sparse_bytes = double(file_info.payload_bytes);
  // On MPI ranks, rows in blocks of equal count: a rank holds every row of its block, dense, so equal counts balance
  // the memory, which decides how many ranks a scene needs. Rows of reflectivity 0 are held but not computed; the
  // compute can be off balance by at most their share (lights, usually a few percent).
  const std::vector<uint64_t> row_work(n, 1);
  auto split = [&](int p) { return dist ? dist::split_by_work(row_work, p) : std::vector<size_t>{0, n}; };
  // Rank 0 draws the pictures: an RGB image, its depth buffer and its colour sums (render.cpp), 35 bytes a pixel.
  const double picture_bytes = (a.png.empty() && a.snapshots.empty()) ? 0.0 : 35.0 * double(width) * double(height);
  const NeedsAt needs = [&](int p) {
    const std::vector<size_t> b = dist::split_by_work(row_work, p);  // p > 1 for a serial run: what mpi would hold
    std::vector<RankNeed> v;
    for (int r = 0; r < p; ++r) {
      const size_t rows = b[r + 1] - b[r];
      v.push_back({rows, sparse_file ? sparse_bytes : (4.0 + (dense16 ? 2.0 : 0.0)) * double(rows) * double(n),
                   vector_bytes(n) + (r == 0 ? picture_bytes : 0)});
    }
    return v;
  };
  const std::vector<size_t> bounds = split(ranks);
  const dist::RowBlock block = dist::block_of(bounds, dist ? rank : 0);
  require_memory_per_rank(limit, needs, ranks, "a solve of " + patches,
                          "bin/radiosity solve ... --backend mpi");
  const double file_bytes = sparse_file ? sparse_bytes : 4.0 * double(block.rows()) * double(n),
               copy_bytes = dense16 ? 2 * n2 : 0;
  hpcgi::comm::agreed([&] {
    hpcgi::require_host_memory("a solve of " + patches + " (the form-factor file's " +
                                   (sparse_file ? file_info.storage + " " + file_info.precision
                                                : std::string("dense float32")) + " values " +
                                   (dist ? "of rank " + std::to_string(rank) + "'s " + std::to_string(block.rows()) +
                                               " rows "
                                         : std::string()) +
                                   gib(file_bytes) + (dense16 ? ", their 16-bit copy " + gib(copy_bytes) : "") +
                                   ", vectors " + gib(vector_bytes(n)) +
                                   (root && picture_bytes > 0 ? ", the picture " + gib(picture_bytes) : "") + ")",
                               file_bytes + copy_bytes + vector_bytes(n) + (root ? picture_bytes : 0));
  });
  hpcgi::Timer t;
  FormFactorRows ff;
  std::unique_ptr<FormFactorMatrix> matrix;
  double rank_read_s = 0, rank_checksum_s = 0, rank_chain_s = 0;
  if (sparse_file) {
    ff.n = n;
    ff.row_end = n;
    matrix = std::make_unique<FormFactorMatrix>(load_form_factor_matrix(a.ff, m, &ff.params));
  } else if (dist) {
#ifdef HAVE_MPI
    dist::FileStats st;
    ff = dist::load_form_factor_rows(a.ff, m, block, &st);
    rank_read_s = st.io_s;
    rank_checksum_s = st.checksum_s;
    rank_chain_s = st.chain_s;
#endif
  } else {
    FormFactors whole = load_form_factors(a.ff, m);
    ff.n = whole.n;
    ff.row_begin = 0;
    ff.row_end = whole.n;
    ff.params = whole.params;
    ff.values = std::move(whole.values);
  }
  const double ff_load_s = t.seconds();
  static const float kNoRows = 0;  // a rank without rows still has a matrix (of none of them)
  System sys = make_system(m, ff.values.empty() ? &kNoRows : ff.values.data());
  if (sparse_file) {
    sys.F = nullptr;
    sys.stored = matrix->view();
  }
  if (dist) {
    sys.rows_begin = block.begin;
    sys.rows_end = block.end;
  }

  // The run's form factors: threshold, storage and precision. The default error reference is solved on the
  // file's values before they are thresholded or rounded (or after the run, when they are not).
  t.reset();
  // Counted over this process's rows (on MPI ranks: summed over the ranks).
  auto kept_at = [&](double threshold) {
    uint64_t k = count_kept(sys.F, n, sys.reflectivity, threshold, block.begin, block.end);
    hpcgi::comm::sum(&k, 1);
    return size_t(k);
  };
  const size_t kept = sparse_file ? matrix->kept() : kept_at(a.threshold);
  const bool dropped = !sparse_file && a.threshold > 0 && kept != kept_at(0);
  size_t rows_needed = 0;
  for (size_t i = block.begin; i < block.end; ++i) rows_needed += row_needed(sys.reflectivity[i]);
  const size_t bridges = sparse_file            ? matrix->bridges()
                         : backend.any_storage ? count_bridges(sys.F, n, sys.reflectivity, a.threshold)
                                               : 0;
  const StorageCounts counts{n, kept, bridges, rows_needed};
  const FFStorage storage = sparse_file          ? matrix->view().storage
                            : a.storage == "auto" ? fewest_bytes_storage(readable_storages(backend), values, counts)
                                                  : parse_ff_storage(a.storage);
  const bool as_file = storage == FFStorage::dense && values == FFValues::float32;
  // A sparse file's values are the run's: its reference is solved on them.
  const bool same_matrix = !have_ref && (sparse_file || (values == FFValues::float32 && !dropped));
  double ref_in_build_s = 0;  // the reference solved here is no part of building the run's form factors
  if (a.verify && !have_ref && !same_matrix) {
    ref = hpcgi::comm::agreed([&] { return converged_reference(sys, ""); });
    ref_in_build_s = ref.seconds;
    have_ref = true;
  }
  double matrix_storage_bytes = 4 * n2;  // all ranks together
  if (as_file) {
    if (dropped) apply_threshold(ff.values.data(), n, a.threshold, block.rows());
  } else if (sparse_file) {
    matrix_storage_bytes = matrix->bytes();
  } else {
    const double bytes = ff_storage_bytes(storage, values, n, kept, counts.bridges);
    // The dense file's values and the copy are held at once while it is built: that is what the limit must allow.
    if (limit > 0 && file_bytes + bytes + vector_bytes(n) > limit)
      throw hpcgi::UsageError("a solve of " + patches + " holds " + gib(file_bytes + bytes + vector_bytes(n)) +
                              " while its " + to_string(storage) + " " + to_string(values) + " form factors (" +
                              gib(bytes) + ") are built from the dense file (" + gib(file_bytes) +
                              "), more than --max-memory-per-rank " + gib(limit) + ": write the file with "
                              "formfactors --storage " + to_string(storage == FFStorage::dense ? FFStorage::compressed
                                                                                             : storage) +
                              " (then only those are held)");
    hpcgi::require_host_memory("the " + std::string(to_string(storage)) + " " + to_string(values) +
                                   " form factors of " + patches + " (" + std::to_string(kept) + " kept)",
                               bytes);
    FFMatrixOptions opt;
    opt.storage = storage;
    opt.values = values;
    opt.threshold = a.threshold;
    matrix = std::make_unique<FormFactorMatrix>(ff.values.data(), n, sys.reflectivity, opt);
    matrix_storage_bytes = matrix->bytes();
    std::vector<float>().swap(ff.values);  // the dense values are no longer needed: give their memory back
    sys.F = nullptr;
    sys.stored = matrix->view();
  }
  size_t rows_without_reflection = 0;
  for (const Rgb& rho : sys.reflectivity) rows_without_reflection += !row_needed(rho);
  // The backends that read any storage skip those rows, and mpi (the same product); the others compute them.
  const size_t skipped_rows = backend.any_storage || backend.distributed ? rows_without_reflection : 0;
  if (cfg.backend == "original")  // RRV's cache lines: a (pointer, float) pair of 16 bytes per kept value, at most
    hpcgi::require_host_memory("backend original's cache lines for " + patches,
                               16.0 * (double(kept) + double(rows_without_reflection) * double(n)));
  const double ff_build_s = t.seconds() - ref_in_build_s;
  const Camera cam = hpcgi::comm::agreed([&] { return parse_view(a.view, m); });
  RenderOptions ropt;
  ropt.exposure = a.exposure;

  const std::set<long> snaps(a.snapshots.begin(), a.snapshots.end());
  std::vector<std::string> snapshot_files;
  IterationCallback cb;
  // On every rank (fetching B is collective), drawn by rank 0. A failure to write is kept until the solve ends: a
  // rank that left the solve early would leave the others waiting in its collectives.
  std::exception_ptr snapshot_error;
  if (!snaps.empty())
    cb = [&](long it, const std::vector<Rgb>& B) {
      if (!snaps.count(it)) return;
      const std::string f = snapshot_file(a, it);
      try {
        if (root && !snapshot_error) write_png(f, render(m, B, cam, width, height, ropt));
      } catch (...) {
        snapshot_error = std::current_exception();
      }
      snapshot_files.push_back(f);
    };
  // Agreed: a refused configuration is refused by every rank before any collective (solve checks first).
  const SolveResult res = hpcgi::comm::agreed([&] { return solve(sys, cfg, cb); });
  hpcgi::comm::agreed([&] {
    if (snapshot_error) std::rethrow_exception(snapshot_error);
  });
  const bool failed = radiosity::failed(res.status);
  Verification v;
  double error = 0;
  if (a.verify && !failed) {
    if (!have_ref) ref = hpcgi::comm::agreed([&] { return converged_reference(sys, ""); });
    if (ref.of.empty())
      ref.of = a.ff + (same_matrix ? "" : " before threshold and rounding") + " (" + patches + ")";
    v = hpcgi::comm::agreed([&] { return verify(sys, cfg, res, same_matrix ? &ref : nullptr); });
    error = max_rel_diff(res.B, ref.B);
  }
  const hpcgi::Outcome outcome = outcome_of(res, cfg, a.verify && !failed ? &v : nullptr);
  const double passes_bytes = res.matrix_bytes * static_cast<double>(res.matrix_passes);
  const bool gpu = res.backend_info.count("gpu") > 0;  // the GPU backends describe their GPU
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
                   {"stop", cfg.steps > 0 ? nlohmann::json() : nlohmann::json(cfg.stop)},
                   {"start", cfg.start},
                   {"omega", cfg.method == "sor" ? nlohmann::json(cfg.omega) : nlohmann::json()},
                   {"history", cfg.history},
                   {"max_iter", cfg.max_iter},
                   {"threads", res.threads},
                   {"hemicube", ff.params.resolution},
                   {"weights", to_string(ff.params.weights)},
                   {"ff_threshold", ff.params.threshold},
                   {"ff_file", a.ff},
                   {"storage", to_string(storage)},
                   {"storage_requested", a.storage},
                   {"ff_precision", to_string(values)},
                   {"threshold", a.threshold},
                   {"channels", cfg.channels},
                   {"reference_ff", a.reference_ff.empty() ? nlohmann::json() : nlohmann::json(a.reference_ff)},
                   {"reference_divide", a.reference_divide > 0 ? nlohmann::json(a.reference_divide) : nlohmann::json()},
                   {"fused", cfg.backend == "cublas" ? nlohmann::json(cfg.fused) : nlohmann::json()},
                   {"distribution", hybrid ? nlohmann::json(cfg.distribution) : nlohmann::json()},
                   {"overlap", hybrid ? nlohmann::json(cfg.overlap) : nlohmann::json()}};
  rec["result"] = {{"status", to_string(res.status)},
                   {"converged", res.status == SolveStatus::converged},
                   {"iterations", res.iterations},
                   {"rel_residual", res.rel_residual},
                   {"max_rel_residual", *std::max_element(res.rel_residual.begin(), res.rel_residual.end())},
                   {"mesh_hash", mesh_hash(m)},
                   {"channels", res.channels},
                   {"kept", kept},
                   {"density", double(kept) / n2},
                   {"skipped_rows", skipped_rows},
                   {"matrix_storage_bytes", matrix_storage_bytes}};
  if (!res.detail.empty()) rec["result"]["detail"] = res.detail;
  hpcgi::record::set_outcome(rec, outcome);
  if (cfg.history) rec["result"]["history"] = history_json(res, cfg);
  if (!failed) {  // the range of B, for scenes whose answer is known in closed form (a closed box: E / (1 - ρ))
    Rgb lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (const Rgb& b : res.B)
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], b[c]);
        hi[c] = std::max(hi[c], b[c]);
      }
    rec["result"]["radiosity_min"] = lo;
    rec["result"]["radiosity_max"] = hi;
  }
  if (a.verify && !failed) {
    rec["result"]["error_vs_reference"] = error;
    rec["result"]["reference"] = {{"of", ref.of},
                                  {"precision", "double"},
                                  {"tol", kReferenceTol},
                                  {"method", ref.method},
                                  {"iterations", ref.iterations},
                                  {"max_rel_residual", ref.max_rel_residual},
                                  {"converged", ref.converged},
                                  {"patches", ref.patches},
                                  {"seconds", ref.seconds}};
  } else {
    rec["result"]["error_vs_reference"] = nullptr;
  }
  if (a.verify && !failed)
    rec["verify"] = {{"reference", holds_all_rows(sys) ? "float64, openmp backend (bit-identical to serial), aos"
                                                       : "float64, mpi backend on the same ranks, aos"},
                     {"reference_iterations", v.reference_iterations},
                     {"max_rel_diff", v.max_rel_diff},
                     {"bound", v.bound},
                     {"agreed", v.agreed}};
  else
    rec["verify"] = {{"agreed", nullptr}};
  const double per_it = res.iterations > 0 ? res.solve_s / static_cast<double>(res.iterations) : 0.0;
  rec["times_s"] = {{"load", load_s},       {"ff_load", ff_load_s},     {"ff_build", ff_build_s},
                    {"setup", res.setup_s},  {"solve", res.solve_s},     {"per_iteration", per_it},
                    {"check", res.check_s},  {"verify", v.seconds},      {"reference", ref.seconds},
                    {"total", total.seconds()}};
  if (gpu) {
    rec["times_s"]["upload"] = res.upload_s;
    rec["times_s"]["transfer"] = res.transfer_s;
    rec["times_s"]["device_compute"] = res.device_compute_s;
    rec["times_s"]["host_compute"] = res.host_compute_s;
  }
  rec["perf"] = {{"matrix_bytes", res.matrix_bytes},
                 {"matrix_passes", res.matrix_passes},
                 {"bandwidth_GBps", res.solve_s > 0 ? passes_bytes / res.solve_s / 1e9 : 0.0},
                 {"peak_rss_bytes", peak_rss_bytes()},
                 {"timer", gpu ? "host wall clock, device synchronised; upload, transfer and device_compute by CUDA "
                                 "events, host_compute by the host's clock"
                               : "host wall clock"}};
  if (gpu) rec["perf"]["transfer_bytes"] = res.transfer_bytes;
  if (dist) {
    rec["params"]["ranks"] = ranks;
    nlohmann::json mpi = mpi_section(needs(ranks), limit);  // collective
    mpi["split"] = "rows in blocks of equal count (the memory of F per rank)";
    mpi["file"] = "each rank reads its rows of the one form-factor file (MPI-IO), the checksum chained over the ranks";
    mpi["rank_read_s"] = hpcgi::comm::gather(rank_read_s);
    mpi["rank_checksum_s"] = hpcgi::comm::gather(rank_checksum_s);
    mpi["rank_chain_wait_s"] = hpcgi::comm::gather(rank_chain_s);
    for (const auto& [key, v] : res.per_rank) mpi["rank_" + key] = v;
    for (const auto& [key, v] : res.comm) mpi[key] = v;
    rec["mpi"] = mpi;
  }
  nlohmann::json info = {{"threads", std::to_string(res.threads)}};
  for (const auto& [key, value] : res.backend_info) info[key] = value;
  rec["backend_info"] = info;

  if (!root) {  // rank 0 reports; the others end with the same status
    hpcgi::finish(outcome, true);
    return 0;
  }
  if (!a.quiet) {
    std::printf("solve: %s, %zu patches, %s %s %s %s, %d threads, %d channel%s\n", a.scene.c_str(), m.size(),
                cfg.method.c_str(), cfg.layout.c_str(), cfg.backend.c_str(), cfg.precision.c_str(), res.threads,
                res.channels, res.channels == 1 ? " (grey scene)" : "s");
    std::printf("  form factors: %s%s %s, threshold %g: %zu of %.0f kept (%.2f%%), %.1f MB; %zu rows skipped (reflectivity 0)\n",
                to_string(storage), a.storage == "auto" ? " (auto: the fewest bytes per step)" : "", to_string(values),
                a.threshold, kept, n2, 100.0 * double(kept) / n2, matrix_storage_bytes / 1e6, skipped_rows);
    if (cfg.stop != "residual-e" || cfg.start != "rrv" || cfg.method == "sor")
      std::printf("  stopping rule %s, start %s%s\n", cfg.steps > 0 ? "(fixed steps)" : cfg.stop.c_str(),
                  cfg.start.c_str(), cfg.method == "sor" ? (", omega " + std::to_string(cfg.omega)).c_str() : "");
    std::printf("  status %s after %ld iterations: relative residual r %.3e g %.3e b %.3e\n", to_string(res.status),
                res.iterations, res.rel_residual[0], res.rel_residual[1], res.rel_residual[2]);
    if (!res.detail.empty()) std::printf("  %s\n", res.detail.c_str());
    if (a.verify && !failed) {
      std::printf("  float64 reference: max relative difference %.3e (bound %.1e): %s\n", v.max_rel_diff, v.bound,
                  v.agreed ? "agreed" : "DISAGREED");
      std::printf("  error against the float64 solution to %.0e of %s: %.3e%s\n", kReferenceTol, ref.of.c_str(),
                  error, ref.converged ? "" : " (that solution did not converge: no error bound)");
    }
    std::printf("  time: load %.3f s, form factors %.3f s, setup %.4f s, solve %.4f s (%.4g ms/iteration, %.2f GB/s)\n",
                load_s, ff_load_s, res.setup_s, res.solve_s, per_it * 1e3,
                res.solve_s > 0 ? passes_bytes / res.solve_s / 1e9 : 0.0);
    if (dist) {
      std::printf("  ranks: %d; rows", ranks);
      for (double r : res.per_rank.at("rows")) std::printf(" %.0f", r);
      std::printf("; F held MiB");
      for (double b : res.per_rank.at("ff_bytes")) std::printf(" %.1f", b / (1 << 20));
      std::printf("; received per iteration KiB");
      for (double b : res.per_rank.at("received_bytes_per_iteration")) std::printf(" %.1f", b / 1024);
      std::printf("; in MPI s");
      for (double x : res.per_rank.at("comm_s")) std::printf(" %.4f", x);
      std::printf("\n");
    }
    if (gpu)
      std::printf("  device: %s; upload of F %.4f s; during the solve: transfers %.4f s (%.3g MB), device compute "
                  "%.4f s, host compute %.4f s\n",
                  res.backend_info.count("gpu") ? res.backend_info.at("gpu").c_str() : "?", res.upload_s,
                  res.transfer_s, res.transfer_bytes / 1e6, res.device_compute_s, res.host_compute_s);
  }
  // A run that is no answer (failed, stopped at --max-iter, disagreed with its check) is no scene and no picture:
  // only its record is written.
  const bool answer = outcome.status == hpcgi::kExitOk;
  if (answer && !a.output_xml.empty()) write_rrv_xml(a.output_xml, m, res.B);
  if (answer && !a.png.empty()) write_png(a.png, render(m, res.B, cam, width, height, ropt));
  if (!a.quiet)
    for (const auto& f : snapshot_files) std::printf("  snapshot %s\n", f.c_str());
  hpcgi::record::emit(rec, a);
  hpcgi::finish(outcome, dist);
  return 0;
}

}  // namespace radiosity::app
