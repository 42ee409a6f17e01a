// What a solve is asked (SolveConfig) and what it says (SolveResult, SolveStatus), and the per-iteration callback:
// the configuration that methods/ and the backends read, apart from the driver (solve.hpp) and its registry, so that
// they need not include the driver.
#pragma once
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/config/choices.hpp"
#include "radiosity/solve/config/stop_rule.hpp"

namespace radiosity {

struct SolveConfig {
  Method method = Method::jacobi;   // jacobi | bicgstab | gauss-seidel | sor (choices.hpp: the enums and their names)
  Layout layout = Layout::aos;      // aos | soa
  std::string backend = "openmp";   // a name from solve_backends()
  Precision precision = Precision::single;  // float | double: the working precision of B and of the sums (F is
                                            //   stored as the System holds it: float32, or 16-bit values widened)
  long steps = 0;                   // > 0: exactly this many Jacobi steps, no tolerance (RRV's default is 32)
  double tol = 1e-6;                // steps == 0: stop when the stopping rule's value is <= tol
  StopRule stop;                    // the stopping rule (stop_rule.hpp): ‖e - A b‖ / ‖e‖ per channel by default
  Start start = Start::rrv;         // b_0: rrv (System::initial, RRV's max(radiosity, emission)) | zero | emission
  bool history = false;             // keep every iterate's norms (SolveResult::history)
  int read_sweeps = 0;              // serial, openmp: after the method, this many read-only sweeps over F's own arrays
                                    //   (SolveResult::read_sweep_s), the product's byte limit in the same process
  double omega = 1.0;               // sor: the relaxation factor, in (0, 2); gauss-seidel is sor with omega 1
  long max_iter = 1000;             // steps == 0: give up after this many iterations
  int threads = 0;                  // openmp: 0 = the OpenMP default; the single-threaded backends ignore it
  float ff_threshold = 0;           // original: keep only F_ij > threshold (RRV's ffTreshold); other backends: 0
  bool fused = false;               // cublas: one Sgemm over the three channels instead of one Sgemv per channel
  double distribution = 0.5;        // hybrid: the first ceil(d n) rows on the GPU, the rest on the CPU; d in [0, 1]
  bool overlap = false;             // hybrid: pinned staging and async copies that overlap the CPU's rows
  Channels channels = Channels::automatic;  // auto: a grey system (is_grey) is solved as one channel where the
                                            //   backend can; 3: always three
};

enum class SolveStatus {
  converged,   // every channel's residual <= tol (as the method measures it, in the working precision)
  max_iter,    // max_iter iterations without reaching tol
  steps_done,  // the fixed number of steps ran
  breakdown,   // BiCG-STAB: ρ = r̂·r, r̂·v or ω ≈ 0 (detail says which, where)
  nonfinite,   // a NaN or Inf in the iterates (or in the input)
  divergent,   // Jacobi (and original): the residual grew far past its start (divergence.hpp; detail says where)
  stagnant,    // Jacobi, Gauss-Seidel, SOR with a tolerance: the residual stopped moving far above it (divergence.hpp;
               //   detail starts "no solution: ")
  unphysical,  // B falls below E beyond the answer's residual and rounding (physical.hpp): ρF amplifies the light
};
const char* to_string(SolveStatus s);
// Whether the run's numbers went wrong (breakdown, nonfinite, divergent, stagnant, unphysical): its B is no answer,
// exit status 3.
bool failed(SolveStatus s);

struct SolveResult {
  std::vector<Rgb> B;             // the radiosity the run ends with (double, whatever the working precision)
  long iterations = 0;            // Jacobi steps, Gauss-Seidel / SOR sweeps or BiCG-STAB iterations (each of two
                                  //   products) that produced B
  int channels = 3;               // channels solved: 1 for a grey system solved once (B's r, g, b are equal)
  Rgb rel_residual{0, 0, 0};      // relative_residual(system, B): recomputed in double, same for every backend
  SolveStatus status = SolveStatus::max_iter;
  std::string detail;             // why a breakdown or nonfinite status, empty otherwise
  long matrix_passes = 0;         // passes over the matrix during the solve (Jacobi 1/step, Gauss-Seidel 1/sweep,
                                  //   BiCG-STAB 2/iteration plus 1 per residual recomputation)
  // cfg.history: the norms of b_0, b_1, ... as the method measured them (BiCG-STAB: the recurrence's residual),
  // with ‖e‖² and ‖r_0‖² per channel, from which any stopping rule's decision can be replayed.
  std::vector<IterateNorms> history;
  Rgb e2{0, 0, 0}, r0_2{0, 0, 0};
  double matrix_bytes = 0;        // bytes one pass reads: 4n² dense float32 (the rows computed), the kept values
                                  //   with their columns for csr, the (pointer, float) pairs for `original`
  int threads = 1;
  double setup_s = 0;             // building the backend's data and loading B0
  double solve_s = 0;             // the iterations, without the time spent in the callback
  double check_s = 0;             // fetching B and recomputing the residual
  // cfg.read_sweeps: the seconds of each read-only sweep over the arrays one pass reads (read_sweep_bytes of them:
  // matrix_bytes, or for dense every row), on the backend's threads, after the method.
  std::vector<double> read_sweep_s;
  double read_sweep_bytes = 0;
  // GPU backends (zero for the others). setup_s includes upload_s; the rest is the solve's, callbacks excluded.
  double upload_s = 0;            // the form factors host -> device (cublas double: with their widening to double)
  double transfer_s = 0;          // copies during the solve: reduction results, hybrid's halves (CUDA events)
  double device_compute_s = 0;    // kernels and cuBLAS calls during the solve (CUDA events)
  double host_compute_s = 0;      // hybrid: the CPU's rows during the solve (host wall clock)
  double transfer_bytes = 0;      // bytes copied between host and device during the solve
  std::map<std::string, std::string> backend_info;  // GPU backends: the GPU, CUDA versions, hybrid's row split
  // Backend mpi: one value per rank, in rank order (rows, bytes of F held, bytes received per iteration, seconds in
  // MPI calls, ...; radiosity/solve/mpi/mpi.cpp says which), and counts that are the same on every rank.
  std::map<std::string, std::vector<double>> per_rank;
  std::map<std::string, double> comm;
};

// Called after every iteration k = 1, 2, ... with the radiosity B_k (report Figure 4.2: snapshots after 1, 2, 4,
// 8, 32 iterations). Its time is not counted in solve_s.
using IterationCallback = std::function<void(long iteration, const std::vector<Rgb>& B)>;

}  // namespace radiosity
