// The radiosity solver's one entry point: solve(system, config, callback) runs one method (jacobi | bicgstab) in
// one layout (aos | soa), one backend and one working precision, and says how it went.
//
// Backends are a registry (solve_backends): one file per backend, one line in solve.cpp. A backend either supplies
// the kernels of kernels.hpp (then Jacobi and BiCG-STAB, written once, run on it) or its own loop (`original`).
// Combinations a backend does not run are refused with hpcgi::UsageError before anything is computed.
#pragma once
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/config/config.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

using BackendRun = SolveResult (*)(const System&, const SolveConfig&, const IterationCallback&);

struct SolveBackend {
  std::string name;
  std::string summary;
  std::vector<Method> methods;  // what it runs
  std::vector<Layout> layouts;
  std::vector<Precision> precisions;
  bool tolerance;     // whether it can stop on a tolerance (false: fixed steps only)
  bool built;         // compiled into this binary
  std::string why_not;
  BackendRun run;
  bool any_storage = false;  // reads F in any storage (System::stored); else dense float32
  bool one_channel = false;  // solves a grey system as one channel
  bool distributed = false;  // runs on MPI ranks, each holding its block of rows of F (System::rows_begin, rows_end)
  bool sparse_storage = false;  // reads csr and compressed F with any values, dense float32 only (the GPU backends)
  bool gpu = false;             // runs on an NVIDIA GPU (--list-backends; the kit's GPU cases)
  bool rrv_loop = false;        // RRV's loop as it was: no history, no stopping rule; the one that takes ff_threshold
  bool read_sweep = false;      // sweeps its matrix's arrays after the method (--read-sweeps)
  bool one_thread = false;      // one thread, one block of rows (gauss-seidel and sor sweep every row in order)
  bool fuses = false;           // takes --fused: the three channels' products as one
  bool splits_rows = false;     // splits F's rows between a GPU and the host (--distribution, --overlap)
  bool cublas = false;          // calls cuBLAS
  bool cusparse = false;        // calls cuSPARSE (the product of csr float32 F: sparse_device.cuh)
};
const std::vector<SolveBackend>& solve_backends();

// Whether backend b reads F stored so (any_storage, sparse_storage; dense float32 every backend reads; runs the CPU
// backends: serial, openmp, mpi).
bool reads_storage(const SolveBackend& b, FFStorage storage, FFValues values);

// Whether this run solves one channel: cfg.channels is auto, the system is grey and the backend can.
bool solve_one_channel(const System& sys, const SolveConfig& cfg);

// The starting vector cfg.start names: sys.initial (rrv), zeros, or the emission.
std::vector<Rgb> start_vector(const System& sys, Start start);

// The backend of that name; throws hpcgi::UsageError for an unknown one or one this binary was built without.
const SolveBackend& require_backend(const std::string& name);
// The backend of that name, or null for an unknown one (built or not).
const SolveBackend* find_backend(const std::string& name);

// Throws hpcgi::UsageError for a configuration no backend runs as asked (a method, layout or precision the backend
// does not run; bicgstab with steps; original without steps; omega outside (0, 2) or without sor; a tolerance not
// in (0, 1) or out of the precision's reach; ...), before any system exists: the one statement of these rules,
// which solve() applies too and an application applies first to refuse a request early.
void check_config(const SolveConfig& cfg);

// Throws hpcgi::UsageError where backend b does not read form factors stored so (reads_storage), naming the backends
// that do: the rule solve() applies to a system, and an application to a request.
void require_storage(const SolveBackend& b, FFStorage storage, FFValues values);

// Throws hpcgi::UsageError for a bad system or configuration (unknown backend; unsupported method, layout,
// precision; bicgstab with steps; original without steps; ...). Numerical failure is not thrown: it is the
// status (breakdown, nonfinite, divergent) for the caller to turn into exit status 3.
SolveResult solve(const System& sys, const SolveConfig& cfg, const IterationCallback& callback = nullptr);

}  // namespace radiosity
