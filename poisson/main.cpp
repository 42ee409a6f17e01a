// bin/poisson: one CG solve of the 2-D Poisson test problem on one backend; prints a summary, optionally appends
// a run record (--record) and writes the solution (--solution).
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <string>

#include "common/cli.hpp"
#include "common/comm.hpp"
#include "common/files.hpp"
#include "common/errors.hpp"
#include "common/launcher.hpp"
#include "common/record.hpp"
#include "common/repetitions.hpp"
#include "common/timer.hpp"
#include "poisson/methods/cg.hpp"
#include "poisson/contract/kernels.hpp"
#include "poisson/methods/mg.hpp"
#include "poisson/verify.hpp"

namespace {

struct Args : hpcgi::record::Options {
  poisson::Config cfg;  // parsed once from the strings below (config_of)
  std::string backend = "serial", variant, precond = "none", method = "cg", halo = "nonblocking";
  std::string precision = "double";  // variant empty: the backend's default (poisson::default_variant)
  double tol = 1e-6;
  long max_iter = 0;
  long steps = 0;  // > 0: exactly this many iterations, no tolerance (a benchmark's time per iteration)
  double min_time = 0;  // --min-time: a short solve repeated, its median repetition kept (common/repetitions.hpp)
  std::string solution_path;
};

// The options' strings parsed once into the configuration's enums (CLI11 checked all but the backend's name).
poisson::Config config_of(const Args& a) {
  poisson::Config c = a.cfg;
  c.backend = poisson::parse_backend(a.backend);
  c.precond = poisson::parse_precond(a.precond);
  c.method = poisson::parse_method(a.method);
  c.halo = poisson::parse_halo(a.halo);
  c.precision = poisson::parse_precision(a.precision);
  c.variant = a.variant.empty() ? poisson::default_variant(c.backend, c.precision, c.precond, c.method)
                                : poisson::parse_variant(a.variant);
  return c;
}

// Writes the N×N solution as raw little-endian float64, row j (y) after row j-1, through a temporary file and
// rename, so a killed run leaves no half-written file.
void write_solution(const std::string& path, const std::vector<double>& x) {
  hpcgi::files::AtomicFile out(path);
  if (std::fwrite(x.data(), sizeof(double), x.size(), out.stream()) != x.size()) out.fail(std::strerror(errno));
  out.commit();
}

// The exit status of a run (common/errors.hpp): 0 converged or the fixed steps done (and agreed with the float64
// check), 3 broken down, 4 stopped at max_iter, 5 the float64 check failed (check: null where none was made).
hpcgi::Outcome outcome_of(const poisson::CgResult& r, double tol, long max_iter, const poisson::Check* check) {
  if (r.status == poisson::Status::breakdown) return {hpcgi::kExitNumerical, r.breakdown};
  if (r.status == poisson::Status::max_iter) {
    char why[160];
    std::snprintf(why, sizeof why, "relative residual %.3e after %ld iterations (--max-iter %ld), above --tol %.1e",
                  r.rel_residual, r.iterations, max_iter, tol);
    return {hpcgi::kExitNotConverged, why};
  }
  if (check && !check->agreed) {
    char why[200];
    std::snprintf(why, sizeof why, "||u - u_h||_inf = %.4e against the exact solution, above the bound %.4e",
                  check->error_inf, check->bound);
    return {hpcgi::kExitDisagreed, why};
  }
  return {};
}

// The record's verify section: the float64 check of the error against the exact solution (verify.hpp), or
// agreed null for a run that is no answer.
nlohmann::json verify_section(const poisson::Check* c) {
  if (!c) return {{"agreed", nullptr}};
  nlohmann::json v = {{"reference", "exact solution u = sin^2(pi x) sin^2(pi y), error in float64"},
                      {"error_inf", c->error_inf},
                      {"bound", c->bound},
                      {"bound_terms", {{"discretisation", c->discretisation}, {"algebraic", c->algebraic},
                                       {"rounding", c->rounding}}},
                      {"agreed", c->agreed}};
  if (c->test_factor != 1.0) v["test_factor"] = c->test_factor;  // HPCGI_TEST_POISSON_BOUND: a planted failure
  return v;
}

// The bytes a solve of `iterations` moves by the backend's data-movement model: bytes_per_iter each, or with
// --method fmg (fmg_levels not empty: the backend's F-cycle per level, and fmg_correction after it) the F-cycle
// and its correction as the first iteration.
double bytes_moved(const std::vector<double>& fmg_levels, double fmg_correction, long iterations,
                   double bytes_per_iter, double vector) {
  if (fmg_levels.empty() || iterations == 0) return iterations * bytes_per_iter;
  double v = fmg_correction;
  for (double l : fmg_levels) v += l;
  return v * vector + (iterations - 1) * bytes_per_iter;
}

// What a run found, for its record and its printed summary (rank 0).
struct Run {
  poisson::CgResult r;
  std::map<std::string, std::string> info;
  bool fixed = false, answer = false;
  long max_iter = 0;
  double alloc_s = 0, asymmetry = 0, total_s = 0;
  int vectors = 0;         // the backend's vectors per iteration
  double vector_bytes = 0; // sizeof(T) N²
  double bytes_per_iter = 0, per_iter = 0, solve_bytes = 0, gbps = 0, dofs = 0;
  std::vector<double> fmg_levels;  // --method fmg: the backend's F-cycle, its vectors per level
  double fmg_correction = 0;       // and what its first iteration adds after it
  std::vector<long> sizes;         // the multigrid hierarchy, finest first
  poisson::Check check;
  hpcgi::Outcome outcome;
  hpcgi::Repetitions reps;  // --min-time
};

// The data-movement figures of a finished run (rank 0).
template <class T>
void add_perf(const Args& a, poisson::Kernels<T>& k, Run& u) {
  const double n2 = static_cast<double>(a.cfg.n) * static_cast<double>(a.cfg.n);
  u.vectors = k.vectors_per_iteration();
  u.vector_bytes = sizeof(T) * n2;
  u.bytes_per_iter = u.vectors * u.vector_bytes;
  u.per_iter = u.r.iterations > 0 ? u.r.solve_s / u.r.iterations : 0.0;
  if (a.cfg.method == poisson::Method::fmg) {
    u.fmg_levels = k.multigrid()->fmg_vectors_per_level();
    u.fmg_correction = k.multigrid()->fmg_correction_vectors();
  }
  u.solve_bytes = bytes_moved(u.fmg_levels, u.fmg_correction, u.r.iterations, u.bytes_per_iter, u.vector_bytes);
  u.gbps = u.r.solve_s > 0 ? u.solve_bytes / u.r.solve_s / 1e9 : 0.0;
  u.dofs = u.r.solve_s > 0 ? n2 / u.r.solve_s : 0.0;  // HPGMG's figure: unknowns over the solve's time
}

nlohmann::json record_of(const Args& a, const Run& u) {
  const poisson::CgResult& r = u.r;
  nlohmann::json rec = hpcgi::record::make("poisson");
  rec["params"] = {{"n", a.cfg.n},         {"backend", to_string(a.cfg.backend)}, {"variant", to_string(a.cfg.variant)},
                   {"precision", a.precision},
                   {"tol", u.fixed ? nlohmann::json() : nlohmann::json(a.tol)},
                   {"steps", a.steps},     {"max_iter", u.max_iter},   {"threads", std::stoi(u.info.at("threads"))},
                   {"ranks", u.info.count("ranks") ? std::stoi(u.info.at("ranks")) : 1}};
  rec["params"]["precond"] = to_string(a.cfg.precond);
  rec["params"]["method"] = to_string(a.cfg.method);
  if (a.cfg.backend == poisson::Backend::mpi) rec["params"]["halo"] = to_string(a.cfg.halo);
  rec["result"] = {{"status", to_string(r.status)},
                   {"converged", r.status == poisson::Status::converged},
                   {"iterations", r.iterations},
                   {"rel_residual", r.rel_residual},
                   {"true_rel_residual", r.true_rel_residual},
                   {"true_residual_meets_tol", u.fixed ? nlohmann::json() : nlohmann::json(r.true_rel_residual <= a.tol)},
                   {"error_inf", r.error_inf},
                   {"h", 1.0 / static_cast<double>(a.cfg.n + 1)}};
  if (!r.breakdown.empty()) rec["result"]["breakdown"] = r.breakdown;
  hpcgi::record::set_outcome(rec, u.outcome);
  rec["verify"] = verify_section(u.answer ? &u.check : nullptr);
  if (!u.sizes.empty()) rec["result"]["mg_levels"] = u.sizes;
  if (a.cfg.check_symmetry) rec["result"]["mg_asymmetry"] = u.asymmetry;
  rec["times_s"] = {{"setup", u.alloc_s + r.init_s}, {"solve", r.solve_s},    {"per_iteration", u.per_iter},
                    {"check", r.check_s},            {"total", u.total_s}};
  rec["perf"] = {{"vectors_per_iteration", u.vectors},
                 {"bytes_per_iteration", u.bytes_per_iter},
                 {"bandwidth_GBps", u.gbps},
                 {"solve_bytes", u.solve_bytes},
                 {"dof_per_s", u.dofs},
                 {"timer", poisson::backend_entry(a.cfg.backend).gpu ? "host wall clock, device synchronised"
                                                                     : "host wall clock"}};
  if (!u.fmg_levels.empty()) {
    rec["perf"]["fmg_vectors_per_level"] = u.fmg_levels;
    rec["perf"]["fmg_correction_vectors"] = u.fmg_correction;
  }
  rec["backend_info"] = u.info;
  if (a.min_time > 0) rec["repetitions"] = hpcgi::to_json(u.reps);
  return rec;
}

void print_summary(const Args& a, const Run& u) {
  const poisson::CgResult& r = u.r;
  std::printf("poisson: N=%ld backend=%s method=%s variant=%s precond=%s precision=%s", a.cfg.n,
              to_string(a.cfg.backend).c_str(), to_string(a.cfg.method).c_str(), to_string(a.cfg.variant).c_str(),
              to_string(a.cfg.precond).c_str(), a.precision.c_str());
  for (const auto& [key, v] : u.info) std::printf(" %s=%s", key.c_str(), v.c_str());
  std::printf("\n  status %s after %ld iterations: relative residual %.3e (true %.3e), ||u - u_h||_inf = %.4e\n",
              to_string(r.status), r.iterations, r.rel_residual, r.true_rel_residual, r.error_inf);
  std::printf("  time: setup %.4f s, solve %.4f s (%.4g ms/iteration, %.4g vectors of N^2 -> %.2f GB/s, "
              "%.4g DOF/s)\n", u.alloc_s + r.init_s, r.solve_s, u.per_iter * 1e3, u.solve_bytes / u.vector_bytes,
              u.gbps, u.dofs);
  if (!hpcgi::describe(u.reps).empty()) std::printf("  timed: %s\n", hpcgi::describe(u.reps).c_str());
  if (!u.sizes.empty())
    std::printf("  multigrid: %zu levels, N = %ld down to %ld, %sV(1,1) red-black Gauss-Seidel\n", u.sizes.size(),
                u.sizes.front(), u.sizes.back(), u.fmg_levels.empty() ? "" : "F-cycle of ");
  if (a.cfg.check_symmetry)
    std::printf("  symmetry: |(M^-1 x).y - x.(M^-1 y)| / |(M^-1 x).y| = %.3e for random x, y\n", u.asymmetry);
  if (!r.breakdown.empty()) std::printf("  breakdown: %s\n", r.breakdown.c_str());
  if (!u.fixed && r.status == poisson::Status::converged && r.true_rel_residual > a.tol)
    std::printf("  note: the true residual %.3e is above tol %.1e: the recursive residual has drifted from it "
                "(precision %s cannot represent x more accurately)\n",
                r.true_rel_residual, a.tol, a.precision.c_str());
}

template <class T>
int solve(const Args& a) {
  hpcgi::Timer total;
  hpcgi::Timer t;
  Run u;
  auto k = poisson::make_kernels<T>(a.cfg);
  u.alloc_s = t.seconds();
  const bool root = k->is_root();
  poisson::Preconditioned* pre = k->multigrid();
  // Before the solve: the check overwrites r and z, which the solve's init resets.
  u.asymmetry = a.cfg.check_symmetry ? poisson::mg_asymmetry(*pre, a.cfg.n) : 0.0;
  u.fixed = a.steps > 0;
  u.max_iter = u.fixed ? a.steps : a.max_iter > 0 ? a.max_iter : poisson::kDefaultMaxIter.of(a.cfg.n);
  const double tol = u.fixed ? 0.0 : a.tol;  // fixed steps: only an exact zero residual stops them early

  hpcgi::Timer since_print;
  auto progress = [&](long it, double rel) {
    if (root && !a.quiet && since_print.seconds() >= 10.0) {
      std::fprintf(stderr, "poisson: iteration %ld, relative residual %.3e\n", it, rel);
      since_print.reset();
    }
  };
  // x = 0 at every solve's start (Kernels::init): a repetition of --min-time solves the same problem again.
  u.r = hpcgi::repeat_for(
      a.min_time, [&] { return poisson::run_config(*k, a.cfg, tol, u.max_iter, progress); },
      [&](const poisson::CgResult& r) { return u.alloc_s + r.init_s + r.solve_s; }, u.reps);
  if (u.fixed && u.r.status == poisson::Status::max_iter) u.r.status = poisson::Status::steps_done;
  const std::vector<double> x = a.solution_path.empty() ? std::vector<double>() : k->solution();
  u.info = k->info();
  // The float64 check of an answer (converged, or the fixed steps done), on every rank alike.
  u.answer = u.r.status == poisson::Status::converged || u.r.status == poisson::Status::steps_done;
  const double rho = u.fixed ? u.r.rel_residual : a.tol, eps = std::numeric_limits<T>::epsilon();
  if (u.answer) u.check = poisson::check_answer(a.cfg.n, rho, eps, u.r.error_inf);
  u.outcome = outcome_of(u.r, a.tol, u.max_iter, u.answer ? &u.check : nullptr);
  if (!root) return u.outcome.status;  // rank 0 reports; the others end with the same status

  add_perf(a, *k, u);
  if (a.cfg.multigrid() && pre) u.sizes = pre->mg_sizes();
  u.total_s = total.seconds();
  const nlohmann::json rec = record_of(a, u);
  if (!a.quiet) print_summary(a, u);
  hpcgi::record::emit(rec, a);
  // A run that is no answer (broken down, stopped at --max-iter, or disagreed with its check) writes no solution:
  // only its record (as bin/radiosity does).
  if (!a.solution_path.empty() && u.outcome.status == hpcgi::kExitOk) write_solution(a.solution_path, x);
  // Every rank has this outcome (the residuals are allreduced; the others returned its status above): agreed, so
  // rank 0 says it once rather than as "rank 0 of P" ending the others.
  hpcgi::finish(u.outcome, /*agreed=*/true);
  return hpcgi::kExitOk;
}

std::string backend_help() {
  std::string s = "Backends:\n";
  for (const auto& b : poisson::backends()) {
    s += "  " + b.name() + std::string(9 - b.name().size(), ' ') + b.summary +
         (b.onesweep ? " [variants: onesweep (default in double), classic]" : " [variant: classic]") +
         (b.multigrid ? " [precond: none, mg] [method: cg, fmg]" : " [precond: none] [method: cg]");
    if (!b.built) s += " [NOT BUILT: " + b.why_not + "]";
    s += "\n";
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  CLI::App app{
      "Conjugate gradients for -Laplace(u) = f on the unit square (5-point stencil, matrix-free, u = 0 on the\n"
      "boundary, N x N interior points, h = 1/(N+1)); test problem u = sin^2(pi x) sin^2(pi y) of Khuvis & Gobbert\n"
      "(HPCF-2014-6). Stops when ||r||/||r0|| <= tol.",
      "poisson"};
  app.add_option("--n", a.cfg.n, "interior points per dimension")->check(hpcgi::integer_in(1, 1LL << 20))->capture_default_str();
  app.add_option("--backend", a.backend, "serial | openmp | mpi | cublas1 | cublas2 | cuda")->capture_default_str();
  CLI::Option* steps = app.add_option("--steps", a.steps, "exactly K iterations, no tolerance (the time per iteration; "
                                      "status steps_done)")->check(hpcgi::integer_in(1, 1LL << 40));
  app.add_option("--max-iter", a.max_iter, "iteration limit with --tol (default max(1000, 4N)); reaching it ends with "
                 "exit status 4")->check(hpcgi::integer_in(1, 1LL << 40))->excludes(steps);
  app.add_option("--tol", a.tol, "relative residual tolerance")->check(hpcgi::positive_finite())->capture_default_str()
      ->excludes(steps);
  app.add_option("--precision", a.precision, "precision of vectors and stencil (dots accumulate in double)")
      ->check(CLI::IsMember(poisson::choice_names<poisson::Precision>()))->capture_default_str();
  app.add_option("--variant", a.variant,
                 "classic: three fused kernels, 11 vectors per iteration; onesweep: Chronopoulos-Gear CG in one pass, "
                 "6 vectors (default in double where the backend has it, see below)")
      ->check(CLI::IsMember(poisson::choice_names<poisson::Variant>()));
  app.add_option("--precond", a.precond,
                 "none: plain CG; mg: CG preconditioned by one geometric multigrid V-cycle (N, N/2, ... 1; red-black "
                 "Gauss-Seidel forward before and backward after the coarse correction, full weighting, bilinear "
                 "prolongation); backends serial, openmp, mpi, cuda")
      ->check(CLI::IsMember(poisson::choice_names<poisson::Precond>()))->capture_default_str();
  app.add_option("--method", a.method,
                 "cg: conjugate gradients (--variant, --precond); fmg: full multigrid, not CG: one F-cycle from the "
                 "coarsest grid up (the V-cycle's smoother and transfers of --precond mg, one V-cycle per level from "
                 "the interpolated coarser solution), then V-cycles until the same ||r||/||r0|| <= tol; an iteration "
                 "is one fine-grid V-cycle; backends serial, openmp, mpi, cuda")
      ->check(CLI::IsMember(poisson::choice_names<poisson::Method>()))->capture_default_str();
  app.add_flag("--check-symmetry", a.cfg.check_symmetry,
               "with --precond mg: before the solve, compare (M^-1 x).y with x.(M^-1 y) for random x, y (printed and "
               "recorded as result.mg_asymmetry)");
  app.add_option("--halo", a.halo, "mpi halo exchange: MPI_Isend/Irecv or MPI_Send/Recv")
      ->check(CLI::IsMember(poisson::choice_names<poisson::Halo>()))->capture_default_str();
  app.add_option("--threads", a.cfg.threads, "OpenMP threads (default: OMP_NUM_THREADS, or 1 per MPI rank)")
      ->check(hpcgi::integer_in(1, 4096));
  hpcgi::add_min_time_option(&app, a.min_time);
  hpcgi::add_record_options(&app, a);
  hpcgi::add_list_backends(app, poisson::describe_backends);
  app.add_option("--solution", a.solution_path, "write u_h as N*N little-endian float64 to FILE");
  app.footer(backend_help() + "\nExamples:\n  bin/poisson --n 512 --backend openmp --threads 2\n"
             "  mpirun -np 4 bin/poisson --n 1024 --backend mpi --halo blocking --record results/poisson.jsonl\n"
             "  bin/poisson --n 4096 --backend openmp --threads 2 --precond mg\n"
             "  bin/poisson --n 8191 --backend openmp --threads 2 --method fmg\n\n" + hpcgi::exit_status_help() +
             "bin/poisson's float64 check: ||u - u_h||_inf against the exact solution must lie within\n"
             "pi^4 h^2/6 + rho ||b||_2 / (8 sin^2(pi h/2)) + eps (rho: --tol, or the relative residual after --steps;\n"
             "eps: the precision's machine epsilon), else exit status 5; recorded as verify.\n");
  int code = 0;
  hpcgi::record::set_command_line(argc, argv);
  if (!hpcgi::parse_cli(app, argc, argv, code)) return code;

  return hpcgi::run_main("poisson", [&]() -> int {
    hpcgi::check_tolerance(a.tol, a.precision);
    hpcgi::check_threads(a.cfg.threads);
    hpcgi::files::check_outputs({{a.record_path, "--record", true}, {a.solution_path, "--solution"}}, {});
    a.cfg = config_of(a);
    const bool mpi = a.cfg.backend == poisson::Backend::mpi;
    if (a.cfg.threads > 0) omp_set_num_threads(a.cfg.threads);
    else if (mpi && !std::getenv("OMP_NUM_THREADS")) omp_set_num_threads(1);
    hpcgi::comm::Session session(mpi);  // rank, size and hosts for the record; MPI_Finalize at the end
    poisson::check_config(a.cfg);       // the one place a configuration is refused
    return a.cfg.precision == poisson::Precision::single ? solve<float>(a) : solve<double>(a);
  });
}
