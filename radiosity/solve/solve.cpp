// The registry of backends and the driver: check the request, build the backend, run the method, check the answer.
#include "radiosity/solve/solve.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>

#include "common/cli.hpp"
#include "common/errors.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/methods/methods.hpp"
#include "radiosity/solve/physical.hpp"

namespace radiosity {
namespace {

template <class T>
SolveResult run_method(KernelFactory<T> make, const System& sys, const SolveConfig& cfg,
                       const IterationCallback& callback) {
  SolveResult res;
  const bool krylov = cfg.method == Method::bicgstab;
  hpcgi::Timer t;
  auto k = make(sys, cfg, krylov ? kBicgstabVectors : kJacobiVectors);
  k->upload(0, sys.initial);
  k->settled();
  res.setup_s = t.seconds();

  t.reset();
  const Rgb e2 = emission_norm2(sys);
  MethodRun run = krylov ? bicgstab<T>(*k, e2, cfg, callback) : stationary<T>(*k, e2, cfg, callback);
  k->settled();
  res.solve_s = t.seconds() - run.callback_s;

  t.reset();
  k->download(run.answer, res.B);
  res.rel_residual = k->relative_residual(sys, res.B);
  res.check_s = t.seconds();
  res.iterations = run.iterations;
  res.status = run.status;
  res.detail = run.detail;
  res.matrix_passes = run.matrix_passes;
  res.history = std::move(run.history);
  res.e2 = e2;
  res.r0_2 = run.r0_2;
  res.matrix_bytes = k->matrix_bytes();
  if (cfg.read_sweeps > 0) std::tie(res.read_sweep_s, res.read_sweep_bytes) = k->read_sweeps(cfg.read_sweeps);
  res.threads = k->threads();
  res.channels = k->channels();
  k->account(res);
  return res;
}

// A backend that supplies kernels: the shared methods run on it, in the precision asked.
template <KernelFactory<float> MakeFloat, KernelFactory<double> MakeDouble>
SolveResult run_kernels(const System& sys, const SolveConfig& cfg, const IterationCallback& callback) {
  return cfg.precision == Precision::double_ ? run_method<double>(MakeDouble, sys, cfg, callback)
                                   : run_method<float>(MakeFloat, sys, cfg, callback);
}

// `value` must be one of those `supported` by the backend.
template <class E>
void check_choice(const std::string& what, E value, const SolveBackend& b, const std::vector<E>& supported) {
  if (std::find(supported.begin(), supported.end(), value) == supported.end())
    throw hpcgi::UsageError("backend '" + b.name + "' does not run " + what + " '" + to_string(value) + "' (it runs " +
                            joined_names(supported) + ")");
}

}  // namespace

const char* to_string(SolveStatus s) {
  switch (s) {
    case SolveStatus::converged: return "converged";
    case SolveStatus::max_iter: return "max_iter";
    case SolveStatus::steps_done: return "steps_done";
    case SolveStatus::breakdown: return "breakdown";
    case SolveStatus::nonfinite: return "nonfinite";
    case SolveStatus::divergent: return "divergent";
    case SolveStatus::stagnant: return "stagnant";
    case SolveStatus::unphysical: return "unphysical";
  }
  return "unknown";
}

bool failed(SolveStatus s) {
  return s == SolveStatus::breakdown || s == SolveStatus::nonfinite || s == SolveStatus::divergent ||
         s == SolveStatus::stagnant || s == SolveStatus::unphysical;
}

// How a backend is built: compiled into this binary or not (why not), and its run. The GPU backends are listed in
// every build, so that asking for one where it was not built says why.
struct Build {
  bool built;
  const char* why_not;
  BackendRun run;
};
#ifdef HAVE_CUDA
#define GPU_BACKEND(make) Build{true, "", run_kernels<make<float>, make<double>>}
#else
#define GPU_BACKEND(make) Build{false, "this build has no CUDA (nvcc was not on PATH when it was compiled)", nullptr}
#endif

#ifdef HAVE_MPI
#define MPI_BACKEND Build{true, "", run_kernels<make_mpi<float>, make_mpi<double>>}
#else
#define MPI_BACKEND Build{false, "this build has no MPI (mpicxx was not on PATH when it was compiled)", nullptr}
#endif

namespace {
// A row's facts beyond its methods, layouts and precisions, by name (SolveBackend's fields of the same names).
enum Facts : unsigned {
  kFixedStepsOnly = 0,   // no tolerance: fixed steps only
  kTolerance = 1,        // stops on a tolerance
  kAnyStorage = 2,       // reads F in any storage
  kOneChannel = 4,       // solves a grey system as one channel
  kDistributed = 8,      // MPI ranks, each its block of rows
  kSparseStorage = 16,   // reads csr and compressed F (the GPU backends)
  kGpu = 32,             // runs on an NVIDIA GPU
  kRrvLoop = 64,         // RRV's loop as it was (backend original)
  kReadSweep = 128,      // sweeps its matrix's arrays (--read-sweeps: the host kernels)
  kOneThread = 256,      // one thread, one block of rows
  kFuses = 512,          // takes --fused
  kSplitsRows = 1024,    // splits F's rows between a GPU and the host
  kCublas = 2048,        // calls cuBLAS
  kCusparse = 4096,      // calls cuSPARSE (csr float32 F)
};
SolveBackend row(const char* name, unsigned facts, std::vector<Method> methods, std::vector<Layout> layouts,
                 std::vector<Precision> precisions, Build build, const char* summary) {
  SolveBackend b{name, summary, std::move(methods), std::move(layouts), std::move(precisions),
                 (facts & kTolerance) != 0, build.built, build.why_not, build.run};
  b.any_storage = (facts & kAnyStorage) != 0;
  b.one_channel = (facts & kOneChannel) != 0;
  b.distributed = (facts & kDistributed) != 0;
  b.sparse_storage = (facts & kSparseStorage) != 0;
  b.gpu = (facts & kGpu) != 0;
  b.rrv_loop = (facts & kRrvLoop) != 0;
  b.read_sweep = (facts & kReadSweep) != 0;
  b.one_thread = (facts & kOneThread) != 0;
  b.fuses = (facts & kFuses) != 0;
  b.splits_rows = (facts & kSplitsRows) != 0;
  b.cublas = (facts & kCublas) != 0;
  b.cusparse = (facts & kCusparse) != 0;
  return b;
}
}  // namespace

const std::vector<SolveBackend>& solve_backends() {
  static const std::vector<Method> kAll = {Method::jacobi, Method::bicgstab, Method::gauss_seidel, Method::sor},
                                   kJacobiBicgstab = {Method::jacobi, Method::bicgstab};
  static const std::vector<Layout> kAosSoa = {Layout::aos, Layout::soa};
  static const std::vector<Precision> kBoth = {Precision::single, Precision::double_};
  auto built_in = [](BackendRun run) { return Build{true, "", run}; };  // the CPU backends: in every build
  static const std::vector<SolveBackend> list = {
      row("original", kFixedStepsOnly | kRrvLoop, {Method::jacobi}, {Layout::aos}, {Precision::single},
          built_in(run_original),
          "RRV's loop rebuilt: per patch a vector of (pointer, form factor) pairs, element by element"),
      row("serial", kTolerance | kAnyStorage | kOneChannel | kReadSweep | kOneThread, kAll, kAosSoa, kBoth,
          built_in(run_kernels<make_serial<float>, make_serial<double>>),
          "kernels written once for both layouts and every storage of F (dense, csr; 16-bit values), one thread"),
      row("openmp", kTolerance | kAnyStorage | kOneChannel | kReadSweep, kAll, kAosSoa, kBoth,
          built_in(run_kernels<make_openmp<float>, make_openmp<double>>),
          "the same kernels, OpenMP threads over static row blocks aligned to cache lines (gauss-seidel and "
          "sor: Gauss-Seidel inside a thread's block, Jacobi between blocks)"),
      row("cuda", kTolerance | kSparseStorage | kGpu | kCusparse, kJacobiBicgstab, {Layout::aos}, kBoth, GPU_BACKEND(make_cuda),
          "GPU, own kernels on r,g,b records: each warp reads two rows of F once for the three channels"),
      row("cublas", kTolerance | kSparseStorage | kGpu | kFuses | kCublas | kCusparse, kJacobiBicgstab, {Layout::soa}, kBoth,
          GPU_BACKEND(make_cublas),
          "GPU, cuBLAS: cublasSgemv per channel (--fused: one cublasSgemm for all three), cublasSdot; "
          "csr float32 by cuSPARSE"),
      row("hybrid", kTolerance | kGpu | kSplitsRows, {Method::jacobi}, {Layout::aos}, kBoth, GPU_BACKEND(make_hybrid),
          "the first ceil(d n) rows on the GPU (cuda's kernels), the rest on OpenMP threads, halves exchanged"),
      row("mpi", kTolerance | kAnyStorage | kOneChannel | kDistributed, kJacobiBicgstab, kAosSoa, kBoth, MPI_BACKEND,
          "MPI ranks, each its block of rows of F (read from the file alone), OpenMP inside; the vector gathered "
          "after every product (MPI_Allgatherv), dots by MPI_Allreduce"),
  };
  return list;
}

bool reads_storage(const SolveBackend& b, FFStorage storage, FFValues values) {
  if (storage == FFStorage::dense && values == FFValues::float32) return true;
  if (b.any_storage) return true;  // runs: the CPU backends only (serial, openmp; mpi, each rank its rows)
  if (storage == FFStorage::runs) return false;
  return b.sparse_storage && storage != FFStorage::dense;
}

const SolveBackend* find_backend(const std::string& name) {
  for (const SolveBackend& x : solve_backends())
    if (x.name == name) return &x;
  return nullptr;
}

bool solve_one_channel(const System& sys, const SolveConfig& cfg) {
  const SolveBackend* b = find_backend(cfg.backend);
  return b && b->one_channel && grey_as_one_channel(sys, cfg);
}

const SolveBackend& require_backend(const std::string& name) {
  const SolveBackend* b = find_backend(name);
  if (!b) {
    std::string names;
    for (const SolveBackend& x : solve_backends()) names += (names.empty() ? "" : " | ") + x.name;
    throw hpcgi::UsageError("unknown solver backend '" + name + "' (known: " + names + ")");
  }
  if (!b->built) throw hpcgi::UsageError("solver backend '" + b->name + "' is not available: " + b->why_not);
  return *b;
}

void check_config(const SolveConfig& cfg) {
  const SolveBackend* b = &require_backend(cfg.backend);
  check_choice("method", cfg.method, *b, b->methods);
  check_choice("layout", cfg.layout, *b, b->layouts);
  check_choice("precision", cfg.precision, *b, b->precisions);
  if (cfg.steps < 0) throw hpcgi::UsageError("steps must be >= 0 (0: stop on the tolerance)");
  if (cfg.steps > 0 && cfg.method == Method::bicgstab)
    throw hpcgi::UsageError("a fixed step count is for jacobi, gauss-seidel and sor; bicgstab stops on the tolerance "
                            "(steps = 0)");
  if (!(cfg.omega > 0 && cfg.omega < 2))
    throw hpcgi::UsageError("omega must lie in (0, 2) (SOR diverges outside), got " + std::to_string(cfg.omega));
  if (cfg.omega != 1 && cfg.method != Method::sor)
    throw hpcgi::UsageError("--omega applies to --method sor, not " + to_string(cfg.method) +
                            " (gauss-seidel is sor with omega 1)");
  if (b->rrv_loop && (cfg.history || cfg.stop != StopRule{}))
    throw hpcgi::UsageError("backend 'original' runs RRV's loop as it was: fixed steps, no history, no stopping rule");
  if (cfg.steps == 0) {
    if (!b->tolerance)
      throw hpcgi::UsageError("backend '" + b->name + "' runs a fixed number of steps (RRV has no tolerance); " +
                              "give steps (RRV's default is 32)");
    if (!(cfg.tol > 0 && std::isfinite(cfg.tol))) {
      char why[96];
      std::snprintf(why, sizeof why, "--tol %g: a tolerance must be a finite number > 0", cfg.tol);
      throw hpcgi::UsageError(why);
    }
    hpcgi::check_tolerance(cfg.tol, to_string(cfg.precision));  // below 1, and reachable in the precision
    if (cfg.max_iter < 1) throw hpcgi::UsageError("max_iter must be >= 1");
  }
  if (cfg.threads < 0) throw hpcgi::UsageError("threads must be >= 0 (0: the OpenMP default)");
  if (cfg.read_sweeps < 0) throw hpcgi::UsageError("read_sweeps must be >= 0");
  if (cfg.read_sweeps > 0 && !b->read_sweep)
    throw hpcgi::UsageError("backend '" + b->name + "' does not sweep its matrix (--read-sweeps: serial and openmp)");
  if (!std::isfinite(cfg.ff_threshold)) throw hpcgi::UsageError("ff_threshold must be a number");
  if (cfg.ff_threshold != 0 && !b->rrv_loop)
    throw hpcgi::UsageError("ff_threshold applies to backend 'original' only (the dense backends use every F_ij)");
}

SolveResult solve(const System& sys, const SolveConfig& cfg, const IterationCallback& callback) {
  check_system(sys);
  const SolveBackend* b = &require_backend(cfg.backend);
  if (!holds_all_rows(sys) && !b->distributed)
    throw hpcgi::UsageError("backend '" + b->name + "' needs every row of F, and this system holds rows " +
                            std::to_string(sys.rows_begin) + ".." + std::to_string(sys.rows_end) +
                            " (an MPI rank's share): use backend mpi");
  if (sys.matrix.n) require_storage(*b, sys.matrix.storage, sys.matrix.values);
  check_config(cfg);
  SolveResult res;
  if (cfg.start == Start::rrv) {
    res = b->run(sys, cfg, callback);
  } else {
    System started = sys;  // the same F (not owned), another b_0
    started.initial = start_vector(sys, cfg.start);
    res = b->run(started, cfg, callback);
  }
  require_physical(sys, res, cfg.steps > 0 ? 0.0 : cfg.tol, cfg.precision);  // every backend's answer, once
  return res;
}

void require_storage(const SolveBackend& b, FFStorage storage, FFValues values) {
  if (reads_storage(b, storage, values)) return;
  std::string which;
  for (const SolveBackend& x : solve_backends())
    if (reads_storage(x, storage, values)) which += (which.empty() ? "" : ", ") + x.name;
  throw hpcgi::UsageError("backend '" + b.name + "' does not read " + to_string(storage) + " " + to_string(values) +
                          " form factors (" + which + " do)");
}

std::vector<Rgb> start_vector(const System& sys, Start start) {
  switch (start) {
    case Start::zero: return std::vector<Rgb>(sys.n, Rgb{0, 0, 0});
    case Start::emission: return sys.emission;
    case Start::rrv: break;
  }
  return sys.initial;
}

}  // namespace radiosity
