// The k-right-hand-side kernels on the host (kernels.hpp's MultiKernels): the serial and openmp backends' k-product.
// k >= 2: F's row blocks (row_blocks.hpp, built once from F in any storage without the rows of reflectivity 0), all
// right-hand sides in one pass over them (linalg.hpp's multi_affine_matvec); k = 1: the solvers' product over F as
// stored (affine_matvec), which reads fewer bytes. The vectors are SOA in T.
#pragma once
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/timer.hpp"
#include "radiosity/solve/host/linalg.hpp"
#include "radiosity/solve/contract/kernels.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

template <class T, class Exec>
class CpuMultiKernels final : public MultiKernels<T> {
 public:
  // Every slot of right-hand side q starts as E[q].
  CpuMultiKernels(const System& sys, const std::vector<std::vector<Rgb>>& E, int vectors, Exec ex)
      : ex_(std::move(ex)), n_(sys.n), F_(system_matrix(sys)), rows_(dense_rows_to_compute(sys.reflectivity)),
        rho_(sys.n) {
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
    hpcgi::Timer t;
    if (E.size() > 1) blocks_.emplace(F_, rows_, ex_.threads());
    build_ms_ = t.seconds() * 1e3;
  }

  size_t rhs() const override { return e_.size(); }
  void upload(int v, size_t q, const std::vector<Rgb>& x) override { load(ex_, slots_.at(v).at(q), x); }
  void download(int v, size_t q, std::vector<Rgb>& x) override { store(ex_, slots_.at(v).at(q), x); }
  void matvec(int y, int x, double a, double c, double d) override {
    std::vector<Soa<T>>& Y = slots_.at(y);
    const std::vector<Soa<T>>& X = slots_.at(x);
    if (blocks_)
      multi_affine_matvec<Exec, T>(ex_, *blocks_, X, Y, rho_, e_, T(a), T(c), T(d));
    else
      affine_matvec(ex_, F_, rows_, X[0], Y[0], rho_, e_[0], T(a), T(c), T(d));
  }
  std::vector<Rgb> dist2(int x, int y) override {
    std::vector<Rgb> out;
    for (size_t q = 0; q < rhs(); ++q) out.push_back(radiosity::dist2(ex_, slots_.at(x)[q], slots_.at(y)[q]));
    return out;
  }
  int threads() const override { return ex_.threads(); }
  double matrix_bytes() const override {
    if (blocks_) return blocks_->bytes();
    if (F_.storage != FFStorage::dense) return stored_bytes();
    return double(value_bytes(F_.values)) * double(rows_.empty() ? n_ : rows_.size()) * double(n_);
  }
  std::vector<std::pair<std::string, double>> facts() const override {
    const double fill = blocks_ ? double(blocks_->nonzeros()) / double(blocks_->columns() * kBlockRows) : 0.0;
    return {{"blocks_bytes", blocks_ ? blocks_->bytes() : 0.0},
            {"blocks_fill", fill},
            {"blocks_build_ms", blocks_ ? build_ms_ : 0.0}};
  }

 private:
  // A sparse F's bytes as the one-right-hand-side backends count them (cpu_kernels.hpp).
  double stored_bytes() const {
    const double v = double(value_bytes(F_.values));
    if (F_.storage == FFStorage::runs)
      return double(F_.row_start[n_]) * v + double(sizeof(FFRun)) * double(F_.run_start[n_]) + 16.0 * double(n_ + 1);
    if (F_.storage == FFStorage::csr) return double(F_.row_start[n_]) * (v + 4) + 8.0 * double(n_ + 1);
    return double(F_.row_start[n_]) * (v + 2) + 8.0 * double(n_ + 1);
  }

  Exec ex_;
  size_t n_;
  FFMatrixView F_;
  std::vector<int32_t> rows_;  // the rows a dense F's product computes; empty: all
  Soa<T> rho_;
  std::vector<Soa<T>> e_;
  std::vector<std::vector<Soa<T>>> slots_;
  std::optional<RowBlockMatrix> blocks_;
  double build_ms_ = 0;
};

}  // namespace radiosity
