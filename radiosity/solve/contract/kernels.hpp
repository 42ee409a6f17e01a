// The contract of a backend that runs the shared methods (after TeaLeaf and BabelStream's Stream.h): it holds
// the system (F, ρ, E) and a few vectors in its own memory and layout, named by slot number, and supplies the
// operations Jacobi and BiCG-STAB are written in. Scalars cross the interface in double, one per channel.
// Each backend (serial, openmp, the GPU ones, mpi) implements this class in its own file; the methods do not change.
#pragma once
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/mesh.hpp"
#include "radiosity/solve/config/config.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

// Whether a backend that solves a grey system as one channel (SolveBackend::one_channel) does so in this run:
// cfg.channels is auto and the system is grey. The driver's solve_one_channel is this and the backend's fact.
inline bool grey_as_one_channel(const System& sys, const SolveConfig& cfg) {
  return cfg.channels == Channels::automatic && is_grey(sys);
}

struct SolveResult;

template <class T>
class Kernels {
 public:
  virtual ~Kernels() = default;
  virtual void upload(int v, const std::vector<Rgb>& x) = 0;   // host -> slot v (converted to T)
  virtual void download(int v, std::vector<Rgb>& x) = 0;       // slot v -> host (x is resized)
  // y = a·x + c·ρ ⊙ (F x) + d·e: the one pass over F (see linalg.hpp). y != x.
  virtual void matvec(int y, int x, double a, double c, double d) = 0;
  virtual Rgb dot(int x, int y) = 0;                             // Σ x·y per channel
  virtual Rgb dist2(int x, int y) = 0;                           // Σ (x - y)² per channel
  virtual void axpby(int y, const Rgb& a, int x, const Rgb& b) = 0;  // y = a ⊙ x + b ⊙ y
  virtual void copy(int y, int x) = 0;
  // max_i |x_ic| and max_i |x_ic - y_ic| per channel, for the ∞-norm stopping rules and the history. This default
  // fetches the vectors (O(n) copies); the host backends reduce in place.
  virtual Rgb max_abs(int x) {
    download(x, host_a_);
    return max_abs_of(host_a_, nullptr);
  }
  virtual Rgb max_abs_diff(int x, int y) {
    download(x, host_a_);
    download(y, host_b_);
    return max_abs_of(host_a_, &host_b_);
  }
  // One sweep of Gauss-Seidel (omega = 1) or SOR from slot x into slot y (linalg.hpp's sor_sweep), returning
  // Σ_i (e - A x)_i² per channel, the residual of x. Only the host backends run it; solve() refuses the others
  // before anything is built, so this default is never reached from there.
  virtual Rgb sor_sweep(int /*y*/, int /*x*/, double /*omega*/) {
    throw hpcgi::UsageError("this backend does not run gauss-seidel or sor (serial and openmp do)");
  }
  virtual int threads() const = 0;
  virtual double matrix_bytes() const = 0;  // bytes one matvec reads from the matrix
  // k read-only sweeps over the arrays of the matrix (common/read_sweep.hpp) on the backend's threads: the seconds of
  // each, and the bytes each read. Only the host backends sweep; solve() refuses --read-sweeps for the others before
  // anything is built, so this default is never reached from there.
  virtual std::pair<std::vector<double>, double> read_sweeps(int /*k*/) {
    throw hpcgi::UsageError("this backend does not sweep its matrix (serial and openmp do)");
  }
  // Channels it solves: 3, or 1 for a grey system solved once (its dots and downloads give r = g = b).
  virtual int channels() const { return 3; }
  // For a backend with a clock of its own (the GPU backends' CUDA events). settled(): returns once all the work
  // handed to the backend is done, and marks the clock; the driver calls it after the setup and after the method, so
  // its host timers stop after the device. account(res): what only the backend knows, e.g. the split of the method's
  // time between those two marks into upload, transfer and compute, and a description of the device.
  virtual void settled() {}
  virtual void account(SolveResult&) const {}
  // The independent check of the answer B (system.hpp's relative_residual), which a backend whose system holds only
  // its rank's rows of F (mpi) adds up across the ranks.
  virtual Rgb relative_residual(const System& sys, const std::vector<Rgb>& B) const {
    return radiosity::relative_residual(sys, B);
  }

 private:
  static Rgb max_abs_of(const std::vector<Rgb>& a, const std::vector<Rgb>* b) {
    Rgb m{0, 0, 0};
    for (size_t i = 0; i < a.size(); ++i)
      for (int c = 0; c < 3; ++c) m[c] = std::max(m[c], std::abs(a[i][c] - (b ? (*b)[i][c] : 0.0)));
    return m;
  }
  std::vector<Rgb> host_a_, host_b_;
};

// The contract of a backend that solves k systems on the same F and ρ at once (the light basis: one right-hand side
// per light, radiosity/relight/): its slots each hold k vectors of three channels, and every slot of right-hand side
// q starts as E_q (the factory's). One product passes over F once for all k. methods/multi_rhs.hpp is written over
// it; the CPU backends (host kernels) and mpi (its row split, the k columns gathered) implement it.
template <class T>
class MultiKernels {
 public:
  virtual ~MultiKernels() = default;
  virtual size_t rhs() const = 0;                                       // k
  virtual void upload(int v, size_t q, const std::vector<Rgb>& x) = 0;  // host -> slot v's vector q
  virtual void download(int v, size_t q, std::vector<Rgb>& x) = 0;     // slot v's vector q -> host
  // Y_q = a·X_q + c·ρ ⊙ (F X_q) + d·E_q for every q < k, in one pass over F. y != x.
  virtual void matvec(int y, int x, double a, double c, double d) = 0;
  virtual std::vector<Rgb> dist2(int x, int y) = 0;                    // Σ (X_q - Y_q)² per channel, for each q
  virtual int threads() const = 0;
  virtual double matrix_bytes() const = 0;  // bytes one k-product reads from (its copy of) F
  // What only the backend knows of its k-product's matrix (e.g. row blocks' bytes, fill and build time), by name.
  virtual std::vector<std::pair<std::string, double>> facts() const { return {}; }
};

}  // namespace radiosity
