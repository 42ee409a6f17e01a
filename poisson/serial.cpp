// The frozen reference: plain loops over an N×N array, no threads, no tricks. Every other backend is checked
// against this one.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common/memory.hpp"

#include "poisson/backends.hpp"

namespace poisson {
namespace {

template <class T>
class Serial final : public Kernels<T> {
 public:
  explicit Serial(long n)
      : g_{n}, n_((hpcgi::require_host_memory("N = " + std::to_string(n), 5.0 * sizeof(T) * n * n), n)), x_(n * n), r_(n * n), p_(n * n), w_(n * n), b_(n * n) {
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) b_[j * n_ + i] = static_cast<T>(g_.b(i, j));
  }

  double init() override {
    double rr = 0;
    for (long k = 0; k < n_ * n_; ++k) {
      x_[k] = 0;
      r_[k] = b_[k];
      p_[k] = b_[k];
      rr += static_cast<double>(r_[k]) * r_[k];
    }
    return rr;
  }

  double calc_w() override {
    apply(p_, w_);
    double pw = 0;
    for (long k = 0; k < n_ * n_; ++k) pw += static_cast<double>(p_[k]) * w_[k];
    return pw;
  }

  double calc_ur(double alpha) override {
    const T a = static_cast<T>(alpha);
    double rr = 0;
    for (long k = 0; k < n_ * n_; ++k) {
      x_[k] += a * p_[k];
      r_[k] -= a * w_[k];
      rr += static_cast<double>(r_[k]) * r_[k];
    }
    return rr;
  }

  void calc_p(double beta) override {
    const T b = static_cast<T>(beta);
    for (long k = 0; k < n_ * n_; ++k) p_[k] = r_[k] + b * p_[k];
  }

  double true_residual2() override {
    std::vector<T> ax(n_ * n_);
    apply(x_, ax);
    double s = 0;
    for (long k = 0; k < n_ * n_; ++k) {
      const double d = static_cast<double>(b_[k]) - ax[k];
      s += d * d;
    }
    return s;
  }

  double error_inf() override {
    double e = 0;
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) e = std::max(e, std::abs(static_cast<double>(x_[j * n_ + i]) - g_.u(i, j)));
    return e;
  }

  std::vector<double> solution() override { return std::vector<double>(x_.begin(), x_.end()); }
  // Unfused loops: [w = Ap] 2, [p·w] 2, [x, r, r·r] 6, [p] 3.
  int vectors_per_iteration() const override { return 13; }
  std::map<std::string, std::string> info() const override { return {{"threads", "1"}}; }

 private:
  // out = A in, with u = 0 outside the grid.
  void apply(const std::vector<T>& in, std::vector<T>& out) const {
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) {
        T s = 4 * in[j * n_ + i];
        if (i > 0) s -= in[j * n_ + i - 1];
        if (i < n_ - 1) s -= in[j * n_ + i + 1];
        if (j > 0) s -= in[(j - 1) * n_ + i];
        if (j < n_ - 1) s -= in[(j + 1) * n_ + i];
        out[j * n_ + i] = s;
      }
  }

  Grid g_;
  long n_;
  std::vector<T> x_, r_, p_, w_, b_;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_serial(const Config& cfg) {
  return std::make_unique<Serial<T>>(cfg.n);
}
template std::unique_ptr<Kernels<float>> make_serial(const Config&);
template std::unique_ptr<Kernels<double>> make_serial(const Config&);

}  // namespace poisson
