// The CPU kernels of the openmp and mpi backends, written once: a block of rows [y0, y0 + ny) of the N×N grid,
// stored with one ghost row above and below and one zero ghost column left and right, so that the stencil has no
// branches. Loops are OpenMP-parallel over rows with the same static schedule everywhere, and the arrays are
// first touched by that schedule, so each thread works on the memory that sits next to its core.
// Dots are accumulated in double and are local to the block: the caller reduces them across ranks.
#pragma once
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "common/memory.hpp"
#include "poisson/problem.hpp"

namespace poisson {

template <class T>
class CpuBlock {
 public:
  CpuBlock(long n, long y0, long ny)
      : g_{n}, n_(n), y0_(y0), ny_(ny), s_(n + 2), size_(checked_size(n, ny)),
        x_(new T[size_]), r_(new T[size_]), p_(new T[size_]), w_(new T[size_]), b_(new T[size_]) {
    // First touch in the loop schedule of the kernels; ghost rows and columns are zero.
#pragma omp parallel for schedule(static)
    for (long jl = -1; jl <= ny_; ++jl)
      for (long c = 0; c < s_; ++c) {
        const long k = (jl + 1) * s_ + c;
        x_[k] = r_[k] = p_[k] = w_[k] = 0;
        const long i = c - 1, j = y0_ + jl;
        b_[k] = (jl >= 0 && jl < ny_ && i >= 0 && i < n_) ? static_cast<T>(g_.b(i, j)) : T(0);
      }
  }

  long rows() const { return ny_; }
  long stride() const { return s_; }
  // Row jl of a vector, jl = -1 and jl = ny are the ghost rows; element 0 of a row is the left ghost column.
  T* row(T* v, long jl) const { return v + (jl + 1) * s_; }
  T* x() { return x_.get(); }
  T* p() { return p_.get(); }

  double init() {
    double rr = 0;
#pragma omp parallel for schedule(static) reduction(+ : rr)
    for (long jl = 0; jl < ny_; ++jl) {
      T *x = row(x_.get(), jl), *r = row(r_.get(), jl), *p = row(p_.get(), jl), *b = row(b_.get(), jl);
#pragma omp simd reduction(+ : rr)
      for (long c = 1; c <= n_; ++c) {
        x[c] = 0;
        r[c] = p[c] = b[c];
        rr += static_cast<double>(b[c]) * b[c];
      }
    }
    return rr;
  }

  // w = A p on the block (ghost rows of p must hold the neighbours' rows); returns the local p·w.
  double calc_w() {
    double pw = 0;
#pragma omp parallel for schedule(static) reduction(+ : pw)
    for (long jl = 0; jl < ny_; ++jl) {
      const T *pc = row(p_.get(), jl), *pu = row(p_.get(), jl - 1), *pd = row(p_.get(), jl + 1);
      T* w = row(w_.get(), jl);
#pragma omp simd reduction(+ : pw)
      for (long c = 1; c <= n_; ++c) {
        const T v = 4 * pc[c] - pc[c - 1] - pc[c + 1] - pu[c] - pd[c];
        w[c] = v;
        pw += static_cast<double>(pc[c]) * v;
      }
    }
    return pw;
  }

  double calc_ur(double alpha) {
    const T a = static_cast<T>(alpha);
    double rr = 0;
#pragma omp parallel for schedule(static) reduction(+ : rr)
    for (long jl = 0; jl < ny_; ++jl) {
      T *x = row(x_.get(), jl), *r = row(r_.get(), jl);
      const T *p = row(p_.get(), jl), *w = row(w_.get(), jl);
#pragma omp simd reduction(+ : rr)
      for (long c = 1; c <= n_; ++c) {
        x[c] += a * p[c];
        const T rn = r[c] - a * w[c];
        r[c] = rn;
        rr += static_cast<double>(rn) * rn;
      }
    }
    return rr;
  }

  void calc_p(double beta) {
    const T b = static_cast<T>(beta);
#pragma omp parallel for schedule(static)
    for (long jl = 0; jl < ny_; ++jl) {
      T* p = row(p_.get(), jl);
      const T* r = row(r_.get(), jl);
#pragma omp simd
      for (long c = 1; c <= n_; ++c) p[c] = r[c] + b * p[c];
    }
  }

  // Local ‖b - A x‖² (ghost rows of x must hold the neighbours' rows).
  double true_residual2() {
    double s = 0;
#pragma omp parallel for schedule(static) reduction(+ : s)
    for (long jl = 0; jl < ny_; ++jl) {
      const T *xc = row(x_.get(), jl), *xu = row(x_.get(), jl - 1), *xd = row(x_.get(), jl + 1);
      const T* b = row(b_.get(), jl);
      for (long c = 1; c <= n_; ++c) {
        const double ax = 4.0 * xc[c] - xc[c - 1] - xc[c + 1] - xu[c] - xd[c];
        const double d = b[c] - ax;
        s += d * d;
      }
    }
    return s;
  }

  // Local max |x - u|.
  double error_inf() {
    double e = 0;
#pragma omp parallel for schedule(static) reduction(max : e)
    for (long jl = 0; jl < ny_; ++jl) {
      const T* x = row(x_.get(), jl);
      for (long c = 1; c <= n_; ++c) e = std::max(e, std::abs(static_cast<double>(x[c]) - g_.u(c - 1, y0_ + jl)));
    }
    return e;
  }

  // Copies the block's rows of x (without ghosts) to out[0 .. ny*n).
  void copy_x(double* out) {
    for (long jl = 0; jl < ny_; ++jl) std::copy(row(x_.get(), jl) + 1, row(x_.get(), jl) + 1 + n_, out + jl * n_);
  }

 private:
  // (ny + 2)(n + 2) values per vector; refuses a block whose 5 vectors will not fit in memory.
  static long checked_size(long n, long ny) {
    const long size = (ny + 2) * (n + 2);
    hpcgi::require_host_memory("N = " + std::to_string(n) + " (" + std::to_string(ny) + " rows here)",
                               5.0 * sizeof(T) * static_cast<double>(size));
    return size;
  }

  Grid g_;
  long n_, y0_, ny_, s_, size_;
  std::unique_ptr<T[]> x_, r_, p_, w_, b_;
};

}  // namespace poisson
