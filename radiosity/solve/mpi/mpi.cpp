// Backend `mpi`: the shared kernels (linalg.hpp) on MPI ranks, each holding its block of rows of F (the system's
// rows_begin..rows_end, read from the form-factor file alone: radiosity/dist/) and whole vectors, OpenMP threads
// over its rows (--threads). Per operation:
//   matvec  this rank's rows of y = a·x + c·ρ ⊙ (F x) + d·e, by the host backends' product (linalg.hpp's
//           affine_matvec: dense, or csr_kernels.hpp's for csr, compressed and runs) on the rank's rows, in the
//           system's storage (a rank's csr, compressed or runs matrix indexes every row and holds only its own:
//           ff_matrix.hpp); x must be whole, so a vector whose rows were changed since it was last whole is first
//           gathered in place (MPI_Allgatherv of every rank's block): in Jacobi that is the radiosity after every
//           step, in BiCG-STAB p and s (and x at a restart);
//   dot, dist2  over this rank's rows, summed over ranks by MPI_Allreduce (3 doubles);
//   axpby, copy  this rank's rows only (O(n/P), no communication).
// A row's sums are those of backend openmp bit for bit in the same storage (the same function for a row, whichever
// rank or thread);
// dots and residual norms add their partial sums in another order, so results agree to rounding, not bits.
// Per rank the record gets its rows, the bytes of F it holds, the bytes it received per iteration and the seconds
// it spent in MPI calls and in its products (account()).
#include <mpi.h>
#include <omp.h>

#include <climits>
#include <cmath>
#include <string>
#include <type_traits>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/host/exec.hpp"
#include "radiosity/solve/core/layout.hpp"
#include "radiosity/solve/host/linalg.hpp"

namespace radiosity {
namespace {

template <class T>
MPI_Datatype mpi_type() {
  return std::is_same_v<T, double> ? MPI_DOUBLE : MPI_FLOAT;
}

// Counts of MPI traffic, kept from the end of the setup to the end of the method (the driver's two settled()).
struct Traffic {
  double gathers = 0, reductions = 0, received_bytes = 0, comm_s = 0, matvec_s = 0;
};

template <class T, template <class> class Layout>
class MpiKernels final : public Kernels<T> {
  using V = Layout<T>;
  // Values of a patch in one piece of a gather: AOS gathers the r,g,b records at once, SOA one array per channel.
  static constexpr int kPerRow = V::kStep == 3 ? 3 : 1;
  static constexpr int kPieces = V::kStep == 3 ? 1 : V::kChannels;

 public:
  MpiKernels(const System& sys, int vectors, int threads)
      : n_(sys.n),
        first_(holds_all_rows(sys) ? 0 : sys.rows_begin),
        last_(holds_all_rows(sys) ? sys.n : sys.rows_end),
        F_(system_matrix(sys)),
        rows_(dense_rows_to_compute(sys.reflectivity)),
        ex_(threads),
        mine_(first_, last_, threads),
        rho_(sys.n),
        e_(sys.n) {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    // Every rank's block, for the gathers; the blocks must tile 0..n in rank order. Every rank sees the same list,
    // so all agree on a refusal.
    const unsigned long long mine[2] = {first_, last_};
    std::vector<unsigned long long> all(2 * size_t(size_));
    MPI_Allgather(mine, 2, MPI_UNSIGNED_LONG_LONG, all.data(), 2, MPI_UNSIGNED_LONG_LONG, MPI_COMM_WORLD);
    bool tiles = all.front() == 0 && all.back() == n_;
    for (int r = 0; r < size_; ++r) {
      tiles = tiles && all[2 * r] <= all[2 * r + 1];
      if (r + 1 < size_) tiles = tiles && all[2 * r + 1] == all[2 * r + 2];
    }
    if (!tiles)
      throw hpcgi::Agreed<hpcgi::UsageError>("backend mpi: the ranks' blocks of rows of F do not cover the " +
                                             std::to_string(n_) + " patches in rank order");
    if (double(n_) * kPerRow > double(INT_MAX))
      throw hpcgi::Agreed<hpcgi::UsageError>("backend mpi: " + std::to_string(n_) +
                                             " patches exceed MPI's int counts in one gather");
    for (int r = 0; r < size_; ++r) {
      counts_.push_back(int((all[2 * r + 1] - all[2 * r]) * kPerRow));
      displs_.push_back(int(all[2 * r] * kPerRow));
    }
    whole_ = first_ == 0 && last_ == n_;
    // Bytes of F this rank holds and one product reads on all ranks together (as backend openmp reads it).
    const double v = double(value_bytes(F_.values));
    if (F_.storage == FFStorage::dense) {
      held_bytes_ = v * double(last_ - first_) * double(n_);
      matrix_bytes_ = v * double(rows_.empty() ? n_ : rows_.size()) * double(n_);
    } else {
      // Entries (compressed: bridges included; runs: stored values) and runs of this rank's rows, as ff_storage_bytes
      // counts them (a csr or compressed entry is one kept value or bridge to it).
      double counts[2] = {double(F_.row_start[last_] - F_.row_start[first_]),
                          F_.run_start ? double(F_.run_start[last_] - F_.run_start[first_]) : 0.0};
      auto bytes = [&] {
        const RunCounts runs{size_t(counts[1]), size_t(counts[0])};
        return ff_storage_bytes(F_.storage, F_.values, n_, size_t(counts[0]), 0, runs);
      };
      held_bytes_ = bytes();
      MPI_Allreduce(MPI_IN_PLACE, counts, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
      matrix_bytes_ = bytes();
    }
    load(ex_, rho_, sys.reflectivity);
    load(ex_, e_, sys.emission);
    vec_ = zero_vectors<V>(ex_, n_, vectors);
    full_.assign(size_t(vectors), true);
  }

  void upload(int v, const std::vector<Rgb>& x) override {
    load(ex_, vec_.at(v), x);
    full_.at(v) = true;
  }
  void download(int v, std::vector<Rgb>& x) override {
    gather(v);
    store(ex_, vec_.at(v), x);
  }
  void matvec(int y, int x, double a, double c, double d) override {
    gather(x);
    hpcgi::Timer t;
    affine_matvec(ex_, F_, rows_, vec_.at(x), vec_.at(y), rho_, e_, T(a), T(c), T(d), first_, last_);
    now_.matvec_s += t.seconds();
    full_.at(y) = whole_;
  }
  Rgb dot(int x, int y) override { return sum(radiosity::dot(mine_, vec_.at(x), vec_.at(y))); }
  Rgb dist2(int x, int y) override { return sum(radiosity::dist2(mine_, vec_.at(x), vec_.at(y))); }
  void axpby(int y, const Rgb& a, int x, const Rgb& b) override {
    radiosity::axpby(mine_, vec_.at(y), a, vec_.at(x), b);
    full_.at(y) = whole_;
  }
  void copy(int y, int x) override {
    radiosity::copy(mine_, vec_.at(y), vec_.at(x));
    full_.at(y) = whole_;
  }
  int threads() const override { return ex_.threads(); }
  int channels() const override { return V::kChannels; }
  // What one product reads from F on all ranks together (as backend openmp reads it on one node).
  double matrix_bytes() const override { return matrix_bytes_; }

  Rgb relative_residual(const System& sys, const std::vector<Rgb>& B) const override {
    Rgb r2 = residual_squares(sys, B);
    MPI_Allreduce(MPI_IN_PLACE, r2.data(), 3, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    const Rgb scale = residual_scale(sys);
    return {std::sqrt(r2[0]) / scale[0], std::sqrt(r2[1]) / scale[1], std::sqrt(r2[2]) / scale[2]};
  }

  // Called after the setup (the method's traffic starts) and after the method (it ends).
  void settled() override {
    if (marks_++ == 0)
      now_ = Traffic{};
    else
      method_ = now_;
  }

  void account(SolveResult& res) const override {
    const double it = res.iterations > 0 ? double(res.iterations) : 1.0;
    const Traffic& m = method_;
    const double mine[] = {double(last_ - first_), held_bytes_,
                           m.received_bytes / it, m.comm_s, m.matvec_s};
    constexpr int kFields = sizeof mine / sizeof mine[0];
    std::vector<double> all(size_t(kFields) * size_t(size_));
    MPI_Allgather(mine, kFields, MPI_DOUBLE, all.data(), kFields, MPI_DOUBLE, MPI_COMM_WORLD);
    const char* names[kFields] = {"rows", "ff_bytes", "received_bytes_per_iteration", "comm_s", "matvec_s"};
    for (int f = 0; f < kFields; ++f)
      for (int r = 0; r < size_; ++r) res.per_rank[names[f]].push_back(all[size_t(r) * kFields + f]);
    res.comm["ranks"] = size_;
    res.comm["allgatherv_per_iteration"] = m.gathers / it;
    res.comm["allreduce_per_iteration"] = m.reductions / it;
    res.comm["allreduce_bytes"] = 3 * sizeof(double);
    res.comm["gather_bytes_per_call"] = double(n_) * V::kChannels * sizeof(T);
    res.backend_info["ranks"] = std::to_string(size_);
    res.backend_info["mpi_library"] = hpcgi::comm::library();
    res.backend_info["gather"] = V::kStep == 3 ? "one MPI_Allgatherv of r,g,b records"
                                               : std::to_string(kPieces) + " MPI_Allgatherv (one per channel array)";
  }

 private:
  // Makes slot v whole on every rank: each rank's block of rows, gathered in place.
  void gather(int v) {
    if (full_.at(v)) return;
    hpcgi::Timer t;
    V& x = vec_.at(v);
    for (int p = 0; p < kPieces; ++p)
      MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, x.data(p), counts_.data(), displs_.data(), mpi_type<T>(),
                     MPI_COMM_WORLD);
    now_.comm_s += t.seconds();
    now_.gathers += 1;
    now_.received_bytes += double(n_ - (last_ - first_)) * V::kChannels * sizeof(T);
    full_.at(v) = true;
  }

  Rgb sum(Rgb partial) {
    hpcgi::Timer t;
    MPI_Allreduce(MPI_IN_PLACE, partial.data(), 3, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    now_.comm_s += t.seconds();
    now_.reductions += 1;
    return partial;
  }

  size_t n_, first_, last_;
  FFMatrixView F_;              // dense: this rank's rows, from first_ on; sparse: every row indexed, its own held
  std::vector<int32_t> rows_;   // the rows a product computes (empty: all); each rank takes those in its block
  OpenMPExec ex_;               // all n rows: loading and fetching whole vectors
  BlockExec mine_;              // this rank's rows
  V rho_, e_;
  std::vector<V> vec_;
  std::vector<bool> full_;      // slot v holds every rank's rows (else only this rank's are current)
  bool whole_ = false;          // one rank holds every row: nothing to gather
  int rank_ = 0, size_ = 1;
  std::vector<int> counts_, displs_;
  double matrix_bytes_ = 0, held_bytes_ = 0;
  int marks_ = 0;
  Traffic now_, method_;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_mpi(const System& sys, const SolveConfig& cfg, int vectors) {
  if (!hpcgi::comm::active())
    throw hpcgi::UsageError("backend mpi needs MPI initialised: run bin/radiosity (which does so for --backend mpi), "
                            "under mpirun -np P");
  if (grey_as_one_channel(sys, cfg)) return std::make_unique<MpiKernels<T, Grey>>(sys, vectors, cfg.threads);
  if (cfg.layout == Layout::soa) return std::make_unique<MpiKernels<T, Soa>>(sys, vectors, cfg.threads);
  return std::make_unique<MpiKernels<T, Aos>>(sys, vectors, cfg.threads);
}
template std::unique_ptr<Kernels<float>> make_mpi(const System&, const SolveConfig&, int);
template std::unique_ptr<Kernels<double>> make_mpi(const System&, const SolveConfig&, int);

}  // namespace radiosity
