// Kernels on the host: the linear algebra of linalg.hpp on vectors of one layout, rows shared out by one
// execution façade. The serial and openmp backends are this class with SerialExec and OpenMPExec. F is the
// system's matrix in whatever storage it has (system_matrix); the rows of patches with reflectivity 0 are skipped.
#pragma once
#include <atomic>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/errors.hpp"
#include "common/read_sweep.hpp"
#include "common/timer.hpp"
#include "radiosity/solve/contract/kernels.hpp"
#include "radiosity/solve/host/linalg.hpp"
#include "radiosity/solve/host/sor_sweep.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity {

template <class T, template <class> class Layout, class Exec>
class CpuKernels final : public Kernels<T> {
  using V = Layout<T>;

 public:
  CpuKernels(const System& sys, int vectors, Exec ex)
      : ex_(std::move(ex)), n_(sys.n), F_(system_matrix(sys)), rows_(dense_rows_to_compute(sys.reflectivity)),
        rho_(sys.n), e_(sys.n) {
    load(ex_, rho_, sys.reflectivity);
    load(ex_, e_, sys.emission);
    vec_ = zero_vectors<V>(ex_, n_, vectors);
  }

  void upload(int v, const std::vector<Rgb>& x) override { load(ex_, vec_.at(v), x); }
  void download(int v, std::vector<Rgb>& x) override { store(ex_, vec_.at(v), x); }
  void matvec(int y, int x, double a, double c, double d) override {
    affine_matvec(ex_, F_, rows_, vec_.at(x), vec_.at(y), rho_, e_, T(a), T(c), T(d));
  }
  Rgb dot(int x, int y) override { return radiosity::dot(ex_, vec_.at(x), vec_.at(y)); }
  Rgb dist2(int x, int y) override { return radiosity::dist2(ex_, vec_.at(x), vec_.at(y)); }
  void axpby(int y, const Rgb& a, int x, const Rgb& b) override { radiosity::axpby(ex_, vec_.at(y), a, vec_.at(x), b); }
  void copy(int y, int x) override { radiosity::copy(ex_, vec_.at(y), vec_.at(x)); }
  Rgb max_abs(int x) override { return radiosity::max_abs_diff(ex_, vec_.at(x), static_cast<const V*>(nullptr)); }
  Rgb max_abs_diff(int x, int y) override { return radiosity::max_abs_diff(ex_, vec_.at(x), &vec_.at(y)); }
  Rgb sor_sweep(int y, int x, double omega) override {
    return radiosity::sor_sweep(ex_, F_, vec_.at(x), vec_.at(y), rho_, e_, T(omega));
  }
  int threads() const override { return ex_.threads(); }
  int channels() const override { return V::kChannels; }
  // Dense: the rows computed times n values; csr, compressed: the entries, their columns or steps, the row starts;
  // runs: the entries, the runs, both row starts.
  double matrix_bytes() const override {
    const double v = double(value_bytes(F_.values));
    if (F_.storage == FFStorage::runs)
      return double(F_.row_start[n_]) * v + double(sizeof(FFRun)) * double(F_.run_start[n_]) + 16.0 * double(n_ + 1);
    if (F_.storage == FFStorage::csr) return double(F_.row_start[n_]) * (v + 4) + 8.0 * double(n_ + 1);
    if (F_.storage == FFStorage::compressed) return double(F_.row_start[n_]) * (v + 2) + 8.0 * double(n_ + 1);
    return v * double(rows_.empty() ? n_ : rows_.size()) * double(n_);
  }
  // k sweeps that only read what a product reads: each array of F (dense: every row) in turn, each thread its share
  // of it (common/read_sweep.hpp), every sweep's sum checked against one computed before the timing.
  std::pair<std::vector<double>, double> read_sweeps(int k) override {
    const std::vector<std::pair<const void*, size_t>> arrays = matrix_arrays();
    double bytes = 0;
    uint64_t want = 0;
    for (const auto& [p, b] : arrays) {
      bytes += double(b);
      want += hpcgi::word_sum(p, b);
    }
    std::vector<double> seconds;
    for (int r = 0; r < k; ++r) {
      std::atomic<uint64_t> sum{0};
      hpcgi::Timer t;
      ex_.each_thread([&](int th, int nt) {
        uint64_t s = 0;
        for (const auto& [p, b] : arrays) s += hpcgi::read_share(p, b, th, nt);
        sum += s;
      });
      seconds.push_back(t.seconds());
      if (sum != want) throw hpcgi::NumericalError("a read sweep over the form factors summed other values than F holds");
    }
    return {seconds, bytes};
  }

 private:
  Exec ex_;
  size_t n_;
  FFMatrixView F_;
  std::vector<int32_t> rows_;  // the rows a dense F's product computes; empty: all
  V rho_, e_;
  std::vector<V> vec_;

  // The arrays a product reads, as matrix_bytes counts them (dense: all n rows), with their bytes.
  std::vector<std::pair<const void*, size_t>> matrix_arrays() const {
    const size_t v = value_bytes(F_.values), rows = n_ + 1;
    if (F_.storage == FFStorage::dense) return {{F_.data, v * n_ * n_}};
    const size_t kept = size_t(F_.row_start[n_]);
    std::vector<std::pair<const void*, size_t>> a = {{F_.data, v * kept}, {F_.row_start, sizeof(int64_t) * rows}};
    if (F_.storage == FFStorage::csr) a.push_back({F_.col, sizeof(int32_t) * kept});
    if (F_.storage == FFStorage::compressed) a.push_back({F_.step, sizeof(uint16_t) * kept});
    if (F_.storage == FFStorage::runs) {
      a.push_back({F_.run, sizeof(FFRun) * size_t(F_.run_start[n_])});
      a.push_back({F_.run_start, sizeof(int64_t) * rows});
    }
    return a;
  }
};

}  // namespace radiosity
