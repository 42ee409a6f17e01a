// The contract every Poisson CG backend fulfils (after TeaLeaf): the CG algorithm lives once in cg.hpp, each
// backend supplies the same fused kernels on its own memory. Scalars cross the interface in double; vectors live
// in the backend in precision T (float or double). Dots are global (MPI backends reduce across ranks).
// Two variants of the iteration (../shared/notes/cg-data-movement.md):
//   classic:  three fused kernels [w = Ap, p·w], [x, r, r·r], [p]: 11 vectors of N² streamed per iteration;
//   onesweep: Chronopoulos-Gear CG, one pass [p, x, r, r·r, r·Ar] that recomputes Ap and Ar from rows in cache
//             and stores no w: read r, p, x, write r, p, x, 6 vectors. Backends that run it derive from
//             OneSweepKernels.
#pragma once
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "poisson/config/config.hpp"
#include "poisson/config/problem.hpp"

namespace poisson {

template <class T>
class OneSweepKernels;
class Preconditioned;

template <class T>
class Kernels {
 public:
  virtual ~Kernels() = default;
  // x = 0, r = p = b; returns r·r.
  virtual double init() = 0;
  // w = A p; returns p·w.
  virtual double calc_w() = 0;
  // x += α p, r -= α w; returns r·r.
  virtual double calc_ur(double alpha) = 0;
  // p = r + β p.
  virtual void calc_p(double beta) = 0;
  // ‖b - A x‖₂², computed from x (not the recursive r).
  virtual double true_residual2() = 0;
  // max |x_ij - u(x_i, y_j)| over the whole grid.
  virtual double error_inf() = 0;
  // The whole solution x (N×N, row j = y index), on the rank that prints (rank 0); empty elsewhere.
  virtual std::vector<double> solution() = 0;
  // Vectors of N² values one iteration streams through memory (the data-movement model of the backend).
  virtual int vectors_per_iteration() const = 0;
  // Backend facts for the record: threads, ranks, halo mode, MPI library, GPU name, ...
  virtual std::map<std::string, std::string> info() const = 0;
  // Whether this process prints and writes records (rank 0 of an MPI run, always true otherwise).
  virtual bool is_root() const { return true; }
  // What the backend runs beyond classic CG, as it declares it (null: not this backend): the one-sweep kernels
  // (--variant onesweep) and the multigrid hierarchy (--precond mg, --method fmg). check_config refuses a request
  // for what a backend lacks before it is made.
  virtual OneSweepKernels<T>* one_sweep() { return nullptr; }
  virtual Preconditioned* multigrid() { return nullptr; }
};

// What one sweep returns: γ = r·r and δ = r·Ar of the new residual.
struct SweepDots {
  double rr = 0, rAr = 0;
};

// A backend that also runs the one-sweep variant. With α_k, β_k from the recurrences of cg.hpp, one sweep does
//   p = r + β p;  x += α p;  r -= α A p;  returns r·r and r·A r of the new r,
// reading r, p, x and writing them once; Ap and Ar are recomputed from neighbouring rows, never stored.
template <class T>
class OneSweepKernels : public Kernels<T> {
 public:
  // r·Ar of the current r (after init: the δ_0 of the first step).
  virtual double r_Ar() = 0;
  virtual SweepDots sweep(double alpha, double beta) = 0;
};

// A backend that also runs CG preconditioned by one multigrid V-cycle (--precond mg, cg.hpp's run_pcg) derives
// from this as well; it holds z and the grid hierarchy of mg.hpp only when it was made with --precond mg or
// --method fmg (Config::multigrid).
class Preconditioned {
 public:
  virtual ~Preconditioned() = default;
  // z = M⁻¹ r: one V-cycle (mg.hpp) with r as the finest right-hand side, from z = 0; returns r·z.
  virtual double precondition() = 0;
  // p = z + β p.
  virtual void calc_p_z(double beta) = 0;
  // A backend may fuse the CG updates around the V-cycle (run_pcg): calc_p_pw does p = z + βp and returns p·Ap
  // without storing Ap, calc_ur_p then x += αp, r -= αAp (Ap recomputed from p) and returns r·r, in place of
  // calc_p_z, the Kernels' calc_w and calc_ur. Backends without them (fused_updates() false) keep those.
  virtual bool fused_updates() const { return false; }
  virtual double calc_p_pw(double /*beta*/) { return 0; }
  virtual double calc_ur_p(double /*alpha*/) { return 0; }
  // --method fmg (cg.hpp run_fmg) on the same hierarchy: solve_cycle(true) improves x by the full-multigrid F-cycle
  // (mg.hpp fmg, from x = 0 after init), solve_cycle(false) by one solver V-cycle (mg.hpp vcycle_solve); each
  // returns r·r of the new x (local to the rank on a distributed block: the caller's backend reduces it). A
  // backend may run the cycles on x itself (openmp, mpi) or on the correction z of the residual equation from z = 0
  // followed by x += z and r = b - A x (serial, cuda): the same iterates up to rounding, and every backend returns
  // the residual of the new x itself (a recursive r -= A z would fall far below it in float).
  virtual double solve_cycle(bool full) = 0;
  // Grid sizes of the hierarchy, finest first (for the record).
  virtual std::vector<long> mg_sizes() const = 0;
  // The data-movement model of solve_cycle(true), the first iteration of --method fmg, on this backend's own
  // kernels, in vectors of N² (for the record's bandwidth): the F-cycle on each level, finest first (mg.hpp's
  // fmg_vectors_per_level with the backend's level kernels), and what the iteration adds after it (x += z, r = b - A x
  // where the cycles run on the correction z; 0 where they run on x).
  virtual std::vector<double> fmg_vectors_per_level() const = 0;
  virtual double fmg_correction_vectors() const = 0;
  // y·(M⁻¹x) for whole-grid vectors given as functions of the point (i, j): r = x (this rank's rows), z = M⁻¹ r,
  // the dot with y reduced over every rank. It overwrites r and z, so it runs before a solve (whose init resets
  // them): the symmetry check of mg.hpp (--check-symmetry) and the tests.
  using GridFn = std::function<double(long i, long j)>;
  virtual double apply_dot(const GridFn& x, const GridFn& y) = 0;
};

// Creates the backend cfg.backend names. Throws hpcgi::UsageError for what check_config (config.hpp) refuses (a
// backend not built in this binary, a variant, preconditioner or method the backend does not have) and for a
// backend whose hardware is absent (a CUDA backend on a machine without a GPU).
template <class T>
std::unique_ptr<Kernels<T>> make_kernels(const Config& cfg);

}  // namespace poisson
