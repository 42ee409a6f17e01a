// Backend `mpi`'s k-right-hand-side kernels (kernels.hpp's MultiKernels): every rank holds the whole F (the
// relighting reads it whole) and whole vectors, but computes only its block of rows: rows split evenly in blocks
// of kBlockRows, the rank's row blocks (row_blocks.hpp) built from its rows alone (those of reflectivity 0 left
// out), its rows of all k products in one pass over them (linalg.hpp's multi_affine_matvec, OpenMP inside), then
// the k columns gathered in place on every rank (one MPI_Allgatherv per right-hand side and channel); dist2 over its
// rows, the k × 3 sums added by one MPI_Allreduce. A row's sums are those of backend openmp's row blocks up to the
// order of additions over the zero columns a block holds for the other ranks' rows: the answers agree to rounding.
#include <mpi.h>

#include <algorithm>
#include <optional>
#include <string>
#include <type_traits>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/host/exec.hpp"
#include "radiosity/solve/host/linalg.hpp"

namespace radiosity {
namespace {

template <class T>
class MpiMultiKernels final : public MultiKernels<T> {
 public:
  MpiMultiKernels(const System& sys, const std::vector<std::vector<Rgb>>& E, int vectors, int threads)
      : n_(sys.n), ex_(threads), rho_(sys.n) {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    if (!holds_all_rows(sys))
      throw hpcgi::Agreed<hpcgi::UsageError>(
          "backend mpi's k-right-hand-side product needs every row of F on every rank");
    const size_t blocks = (n_ + kBlockRows - 1) / kBlockRows;
    for (int r = 0; r <= size_; ++r) {
      const size_t row = std::min(n_, blocks * size_t(r) / size_t(size_) * kBlockRows);
      if (r < size_) displs_.push_back(int(row));
      if (r > 0) counts_.push_back(int(row) - displs_[size_t(r - 1)]);
    }
    first_ = size_t(displs_[size_t(rank_)]);
    last_ = first_ + size_t(counts_[size_t(rank_)]);
    mine_.emplace(first_, last_, threads);
    const std::vector<int32_t> all = dense_rows_to_compute(sys.reflectivity);
    std::vector<int32_t> rows;
    for (size_t i = first_; i < last_; ++i)
      if (all.empty() || std::binary_search(all.begin(), all.end(), int32_t(i))) rows.push_back(int32_t(i));
    hpcgi::Timer t;
    if (!rows.empty()) blocks_.emplace(system_matrix(sys), rows, ex_.threads());
    build_ms_ = t.seconds() * 1e3;
    load(ex_, rho_, sys.reflectivity);
    for (const std::vector<Rgb>& e : E) {
      e_.emplace_back(n_);
      load(ex_, e_.back(), e);
    }
    slots_.resize(size_t(vectors));
    for (std::vector<Soa<T>>& s : slots_)
      for (const std::vector<Rgb>& e : E) {
        s.emplace_back(n_);
        load(ex_, s.back(), e);
      }
  }

  size_t rhs() const override { return e_.size(); }
  void upload(int v, size_t q, const std::vector<Rgb>& x) override { load(ex_, slots_.at(v).at(q), x); }
  void download(int v, size_t q, std::vector<Rgb>& x) override { store(ex_, slots_.at(v).at(q), x); }
  void matvec(int y, int x, double a, double c, double d) override {
    std::vector<Soa<T>>& Y = slots_.at(y);
    const std::vector<Soa<T>>& X = slots_.at(x);
    if (blocks_) {
      multi_affine_matvec<OpenMPExec, T>(ex_, *blocks_, X, Y, rho_, e_, T(a), T(c), T(d));
    } else {  // this rank's rows all have reflectivity 0 (or it has none): y = a·x + d·e
      for (size_t q = 0; q < rhs(); ++q)
        for (int ch = 0; ch < 3; ++ch)
          for (size_t i = first_; i < last_; ++i) Y[q](i, ch) = T(a) * X[q](i, ch) + T(d) * e_[q](i, ch);
    }
    const MPI_Datatype type = std::is_same_v<T, double> ? MPI_DOUBLE : MPI_FLOAT;
    for (Soa<T>& v : Y)
      for (int ch = 0; ch < 3; ++ch)
        MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, v.data(ch), counts_.data(), displs_.data(), type,
                       MPI_COMM_WORLD);
  }
  std::vector<Rgb> dist2(int x, int y) override {
    std::vector<Rgb> out;
    for (size_t q = 0; q < rhs(); ++q) out.push_back(radiosity::dist2(*mine_, slots_.at(x)[q], slots_.at(y)[q]));
    MPI_Allreduce(MPI_IN_PLACE, out.data()->data(), int(3 * out.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return out;
  }
  int threads() const override { return ex_.threads(); }
  // What one k-product reads on all ranks together: every rank's row blocks.
  double matrix_bytes() const override {
    double b = blocks_ ? blocks_->bytes() : 0.0;
    MPI_Allreduce(MPI_IN_PLACE, &b, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return b;
  }
  std::vector<std::pair<std::string, double>> facts() const override {
    return {{"ranks", double(size_)}, {"rank_rows", double(last_ - first_)}, {"blocks_build_ms", build_ms_}};
  }

 private:
  size_t n_, first_ = 0, last_ = 0;
  OpenMPExec ex_;                 // all n rows: loading and fetching whole vectors; the product's threads
  std::optional<BlockExec> mine_;  // this rank's rows
  Soa<T> rho_;
  std::vector<Soa<T>> e_;
  std::vector<std::vector<Soa<T>>> slots_;
  std::optional<RowBlockMatrix> blocks_;
  std::vector<int> counts_, displs_;
  int rank_ = 0, size_ = 1;
  double build_ms_ = 0;
};

}  // namespace

template <class T>
std::unique_ptr<MultiKernels<T>> make_multi_mpi(const System& sys, const std::vector<std::vector<Rgb>>& E,
                                                const SolveConfig& cfg, int vectors) {
  if (!hpcgi::comm::active())
    throw hpcgi::UsageError("backend mpi needs MPI initialised: run bin/radiosity (which does so for --backend mpi), "
                            "under mpirun -np P");
  return std::make_unique<MpiMultiKernels<T>>(sys, E, vectors, cfg.threads);
}
template std::unique_ptr<MultiKernels<float>> make_multi_mpi(const System&, const std::vector<std::vector<Rgb>>&,
                                                             const SolveConfig&, int);
template std::unique_ptr<MultiKernels<double>> make_multi_mpi(const System&, const std::vector<std::vector<Rgb>>&,
                                                              const SolveConfig&, int);

}  // namespace radiosity
