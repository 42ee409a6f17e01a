// The frozen reference: plain loops over an N×N array, no threads, no tricks. Every other backend is checked
// against this one.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common/memory.hpp"

#include "poisson/contract/backends.hpp"
#include "poisson/contract/stencil.hpp"
#include "poisson/methods/mg.hpp"

namespace poisson {
namespace {

// v at point (i, j) of an unpadded n×n array, zero outside the grid (u = 0 on the boundary).
template <class T>
T at(const std::vector<T>& v, long n, long i, long j) {
  return i >= 0 && i < n && j >= 0 && j < n ? v[j * n + i] : T(0);
}

// (A v) at point (i, j) with diagonal d: the stencil of stencil.hpp, neighbours outside the grid zero.
template <class T>
T stencil_at(const std::vector<T>& v, long n, long i, long j, T d) {
  return five_point(d, v[j * n + i], at(v, n, i - 1, j), at(v, n, i + 1, j), at(v, n, i, j - 1), at(v, n, i, j + 1));
}

// The reference level kernels of mg.hpp: plain loops over unpadded n×n arrays, neighbours outside the grid
// tested for and taken as zero. Level 0's x is z, its b is r and its residual w (free while z is made).
template <class T>
class SerialMg final : public MgLevels {
 public:
  SerialMg(long n, std::vector<T>& z, std::vector<T>& r, std::vector<T>& w) {
    const std::vector<double> edge = mg_edge_terms(n);
    for (long m : mg_level_sizes(n)) {
      Level lv{m, {}, {}, {}, nullptr, nullptr, nullptr, edge[lv_.size()]};
      if (m == n) {
        lv.x = &z, lv.b = &r, lv.r = &w;
      } else {
        lv.ox.resize(m * m), lv.ob.resize(m * m), lv.orr.resize(m * m);
      }
      lv_.push_back(std::move(lv));
    }
    for (auto& lv : lv_)
      if (lv.n != n) lv.x = &lv.ox, lv.b = &lv.ob, lv.r = &lv.orr;
  }
  int levels() const override { return static_cast<int>(lv_.size()); }
  long n(int l) const { return lv_[l].n; }
  void zero(int l) override { std::fill(lv_[l].x->begin(), lv_[l].x->end(), T(0)); }
  void smooth(int l, int colour) override {
    const long n = lv_[l].n;
    std::vector<T>& x = *lv_[l].x;
    const std::vector<T>& b = *lv_[l].b;
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i)
        if ((i + j) % 2 == colour)
          x[j * n + i] = plus_neighbours(b[j * n + i], at(x, n, i - 1, j), at(x, n, i + 1, j), at(x, n, i, j - 1),
                                         at(x, n, i, j + 1)) /
                         diag(lv_[l], i, j);
  }
  void restrict_residual(int l) override {
    const long n = lv_[l].n, nc = lv_[l + 1].n;
    const std::vector<T>&x = *lv_[l].x, &b = *lv_[l].b;
    std::vector<T>& r = *lv_[l].r;
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i) r[j * n + i] = b[j * n + i] - stencil_at(x, n, i, j, diag(lv_[l], i, j));
    std::vector<T>& bc = *lv_[l + 1].b;
    for (long J = 0; J < nc; ++J)
      for (long I = 0; I < nc; ++I) {
        T s = 0;
        for (long dj = -1; dj <= 1; ++dj)
          for (long di = -1; di <= 1; ++di)
            s += weight(di) * weight(dj) * at(r, n, 2 * I + 1 + di, 2 * J + 1 + dj);
        bc[J * nc + I] = s;
      }
  }
  void prolong_add(int l) override {
    const long n = lv_[l].n, nc = lv_[l + 1].n;
    std::vector<T>& x = *lv_[l].x;
    const std::vector<T>& xc = *lv_[l + 1].x;
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i) {
        // The coarse points (I, J) with |2I+1 - i| <= 1 and |2J+1 - j| <= 1.
        T s = 0;
        for (long J = (j - 2) / 2; J <= j / 2; ++J)
          for (long I = (i - 2) / 2; I <= i / 2; ++I)
            if (std::abs(2 * I + 1 - i) <= 1 && std::abs(2 * J + 1 - j) <= 1)
              s += weight(2 * I + 1 - i) * weight(2 * J + 1 - j) * at(xc, nc, I, J);
        x[j * n + i] += s;
      }
  }

 private:
  struct Level {
    long n;
    std::vector<T> ox, ob, orr;  // storage of the coarse levels
    std::vector<T>*x, *b, *r;
    double e;  // added to the diagonal of the last row and column (mg.hpp)
  };
  static T diag(const Level& lv, long i, long j) {
    return T(4 + (i == lv.n - 1 ? lv.e : 0) + (j == lv.n - 1 ? lv.e : 0));
  }
  static T weight(long d) { return d == 0 ? T(1) : T(0.5); }
  std::vector<Level> lv_;
};

template <class T>
class Serial final : public Kernels<T>, public Preconditioned {
 public:
  explicit Serial(const Config& cfg)
      : g_{cfg.n},
        n_((hpcgi::require_host_memory("N = " + std::to_string(cfg.n) +
                                           (cfg.multigrid() ? " with multigrid" : ""),
                                       sizeof(T) * (5.0 * cfg.n * cfg.n +
                                                    (cfg.multigrid() ? cfg.n * cfg.n + mg_extra_values(cfg.n)
                                                                         : 0.0))),
            cfg.n)),
        fmg_(cfg.method == Method::fmg), x_(n_ * n_), r_(n_ * n_), p_(n_ * n_), w_(n_ * n_), b_(n_ * n_) {
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) b_[j * n_ + i] = static_cast<T>(g_.b(i, j));
    if (cfg.multigrid()) {
      z_.resize(n_ * n_);
      mg_ = std::make_unique<SerialMg<T>>(n_, z_, r_, w_);
    }
  }

  double precondition() override {
    vcycle(*mg_);
    double rz = 0;
    for (long k = 0; k < n_ * n_; ++k) rz += static_cast<double>(r_[k]) * z_[k];
    return rz;
  }
  // The cycles on the correction z of the residual equation A z = r from z = 0 (kernels.hpp), then x += z and the
  // residual of the new x.
  double solve_cycle(bool full) override {
    full ? fmg(*mg_) : vcycle_solve(*mg_, 0, true);
    return correct();
  }

 private:
  // x += z; r = b - A x, recomputed from the new x (not r -= A z: in float that recursion falls far below the true
  // residual, and the stopping test reads ‖b - A x‖ as openmp's and mpi's do); returns r·r.
  double correct() {
    for (long k = 0; k < n_ * n_; ++k) x_[k] += z_[k];
    double rr = 0;
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) {
        const long k = j * n_ + i;
        r_[k] = b_[k] - stencil_at(x_, n_, i, j, T(4));
        rr += static_cast<double>(r_[k]) * r_[k];
      }
    return rr;
  }

 public:
  void calc_p_z(double beta) override {
    const T b = static_cast<T>(beta);
    for (long k = 0; k < n_ * n_; ++k) p_[k] = z_[k] + b * p_[k];
  }
  std::vector<long> mg_sizes() const override { return mg_level_sizes(n_); }
  std::vector<double> fmg_vectors_per_level() const override {
    return poisson::fmg_vectors_per_level(n_, kSeparateLevelKernels);
  }
  double fmg_correction_vectors() const override { return kFmgCorrectionVectors; }
  Preconditioned* multigrid() override { return this; }
  double apply_dot(const GridFn& x, const GridFn& y) override {
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) r_[j * n_ + i] = static_cast<T>(x(i, j));
    vcycle(*mg_);
    double s = 0;
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) s += static_cast<double>(z_[j * n_ + i]) * y(i, j);
    return s;
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
  // Unfused loops: [w = Ap] 2, [p·w] 2, [x, r, r·r] 6, [p] 3; with multigrid (mg_vectors, kernels.hpp) [r·z] 2
  // and the V-cycle; fmg after its F-cycle: the V-cycle, [x += z] 3, [r = b - Ax, r·r] 3.
  int vectors_per_iteration() const override {
    return mg_ ? (fmg_ ? kFmgCorrectionVectors : 13 + 2) + mg_vectors_per_cycle(n_) : kVectorsSerial;
  }
  std::map<std::string, std::string> info() const override { return {{"threads", "1"}}; }

 private:
  // out = A in, with u = 0 outside the grid.
  void apply(const std::vector<T>& in, std::vector<T>& out) const {
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) out[j * n_ + i] = stencil_at(in, n_, i, j, T(4));
  }

  Grid g_;
  long n_;
  bool fmg_;
  std::vector<T> x_, r_, p_, w_, b_, z_;
  std::unique_ptr<SerialMg<T>> mg_;
};

}  // namespace

POISSON_BACKEND_FACTORY(make_serial, Serial)

}  // namespace poisson
