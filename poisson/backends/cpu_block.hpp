// The CPU kernels of the openmp and mpi backends, written once: a block of rows [y0, y0 + ny) of the N×N grid,
// stored with two ghost rows above and below (the one-sweep variant reads two rows beyond its own; the classic
// kernels one) and one zero ghost column left and right, so that the stencil has no branches. Loops are
// OpenMP-parallel over rows with the same static schedule everywhere (OpenMP's: the first ny mod T threads get one
// row more), and the arrays are first touched by that schedule, so each thread works on the memory that sits next
// to its core. Dots are accumulated in double and are local to the block: the caller reduces them across ranks.
#pragma once
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/memory.hpp"
#include "poisson/contract/kernels.hpp"
#include "poisson/contract/stencil.hpp"
#include "poisson/config/problem.hpp"

namespace poisson {

// Rows [begin, end) of thread t out of nt over rows [0, ny): the split of OpenMP's schedule(static).
inline std::pair<long, long> static_rows(long ny, int t, int nt) {
  const long q = ny / nt, rem = ny % nt;
  const long begin = t * q + std::min<long>(t, rem);
  return {begin, begin + q + (t < rem ? 1 : 0)};
}

template <class T>
class CpuBlock {
 public:
  // Rows [y0, y0 + ny) of the N×N grid, N = n: the one-sweep variant needs y0 to tell the ghost rows outside the
  // grid (always zero) from those that hold a neighbour's rows. With fmg (--method fmg, which works on x and b
  // alone) p and w are neither allocated nor touched, r is allocated but only the rows the multigrid level kernels
  // use are ever touched (mg_cpu.hpp: a few residual rows per thread; an untouched page reads as zero and costs
  // nothing), ‖b‖² is summed in the pass that makes b, and calc_w, calc_ur, calc_p, r_Ar, sweep must not be called.
  CpuBlock(long n, long y0, long ny, bool fmg = false)
      : g_{n}, tab_(g_), n_(n), y0_(y0), ny_(ny), s_(n + 2), fmg_(fmg), size_(checked_size(n, ny, fmg)),
        x_(hpcgi::huge_array<T>(size_)), r_(hpcgi::huge_array<T>(size_)),
        p_(fmg ? nullptr : hpcgi::huge_array<T>(size_)), w_(fmg ? nullptr : hpcgi::huge_array<T>(size_)),
        b_(hpcgi::huge_array<T>(size_)) {
    // First touch of the interior rows in the loop schedule of the kernels; ghost rows and columns are zero.
    auto touch = [this](long jl) {
      double bb = 0;
      const bool inside = jl >= 0 && jl < ny_;
      for (long c = 0; c < s_; ++c) {
        const long k = (jl + kGhost) * s_ + c;
        x_[k] = 0;
        if (!fmg_ || !inside) r_[k] = 0;
        if (p_) p_[k] = w_[k] = 0;
        const long i = c - 1, j = y0_ + jl;
        const T b = (inside && i >= 0 && i < n_) ? static_cast<T>(tab_.b(i, j)) : T(0);
        b_[k] = b;
        bb += static_cast<double>(b) * b;
      }
      return bb;
    };
    double bb = 0;
#pragma omp parallel for schedule(static) reduction(+ : bb)
    for (long jl = 0; jl < ny_; ++jl) bb += touch(jl);
    bb_ = bb;
    for (long g = 1; g <= kGhost; ++g) {
      touch(-g);
      touch(ny_ - 1 + g);
    }
  }

  static constexpr long kGhost = 2;
  long rows() const { return ny_; }
  long stride() const { return s_; }
  // Row jl of a vector, jl = -2, -1 and ny, ny + 1 are the ghost rows; element 0 of a row is the left ghost
  // column. Rows are contiguous, so ghost rows -2, -1 (and ny, ny + 1) are one block of 2 s values.
  T* row(T* v, long jl) const { return v + (jl + kGhost) * s_; }
  T* x() { return x_.get(); }
  T* p() { return p_.get(); }
  T* r() { return r_.get(); }
  T* w() { return w_.get(); }
  T* b() { return b_.get(); }

  // x = 0, r = p = b; returns the local ‖b‖². With fmg only the latter: x is zero from the first touch, and the
  // F-cycle writes x before it reads it.
  double init() {
    if (fmg_) return bb_;
    double rr = 0;
#pragma omp parallel for schedule(static) reduction(+ : rr)
    for (long jl = 0; jl < ny_; ++jl) {
      T *x = row(x_.get(), jl), *r = row(r_.get(), jl), *b = row(b_.get(), jl);
#pragma omp simd reduction(+ : rr)
      for (long c = 1; c <= n_; ++c) {
        x[c] = 0;
        r[c] = b[c];
        rr += static_cast<double>(b[c]) * b[c];
      }
      std::copy(b + 1, b + 1 + n_, row(p_.get(), jl) + 1);  // p = b (the row of b is in cache)
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
        const T v = five_point_rows(pc, pu, pd, c);
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

  // Local r·Ar (ghost rows -1 and ny of r must hold the neighbours' rows).
  double r_Ar() {
    double s = 0;
#pragma omp parallel for schedule(static) reduction(+ : s)
    for (long jl = 0; jl < ny_; ++jl) s += row_dot_stencil(row(r_.get(), jl - 1), row(r_.get(), jl),
                                                           row(r_.get(), jl + 1));
    return s;
  }

  // The one-sweep iteration on the block (ghost rows -2, -1, ny, ny + 1 of r and p must hold the neighbours'
  // rows): p = r + βp, x += αp, r -= α Ap; returns the local r·r and r·Ar of the new r.
  // Each thread walks down its rows once, in place: at row y it makes p_k[y] (into a ring of 3 rows, and into p),
  // then r_{k+1}[y-1] from the ring (into a second ring, and into r), then the r·Ar term of row y-2. A thread's
  // rows need two rows of old r and p beyond each end, which its neighbours overwrite as they go: every thread
  // first copies the rows it needs, then all wait at one barrier, then sweep. Rows outside the grid stay zero.
  SweepDots sweep(double alpha, double beta) {
    const T a = static_cast<T>(alpha), b = static_cast<T>(beta);
    const int nt = omp_get_max_threads();
    if (static_cast<int>(scratch_.size()) != nt) scratch_.assign(nt, Scratch(s_));
    double rr = 0, rar = 0;
#pragma omp parallel num_threads(nt) reduction(+ : rr, rar)
    {
      const int t = omp_get_thread_num();
      const auto [y0, y1] = static_rows(ny_, t, omp_get_num_threads());
      Scratch& sc = scratch_[t];
      if (y1 > y0)
        for (int k = 0; k < 2; ++k) {  // old r and p of rows y0-2, y0-1 and y1, y1+1
          std::copy_n(row(r_.get(), y0 - 2 + k), s_, sc.edge_r(k));
          std::copy_n(row(p_.get(), y0 - 2 + k), s_, sc.edge_p(k));
          std::copy_n(row(r_.get(), y1 + k), s_, sc.edge_r(2 + k));
          std::copy_n(row(p_.get(), y1 + k), s_, sc.edge_p(2 + k));
        }
#pragma omp barrier
      if (y1 > y0) {
        const SweepDots d = sweep_rows(y0, y1, a, b, sc);
        rr += d.rr;
        rar += d.rAr;
      }
    }
    return {rr, rar};
  }

  // Local ‖b - A x‖² (ghost rows of x must hold the neighbours' rows).
  double true_residual2() {
    double s = 0;
#pragma omp parallel for schedule(static) reduction(+ : s)
    for (long jl = 0; jl < ny_; ++jl) {
      const T *xc = row(x_.get(), jl), *xu = row(x_.get(), jl - 1), *xd = row(x_.get(), jl + 1);
      const T* b = row(b_.get(), jl);
      for (long c = 1; c <= n_; ++c) {
        const double ax = five_point<double>(4.0, xc[c], xc[c - 1], xc[c + 1], xu[c], xd[c]);
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
      for (long c = 1; c <= n_; ++c) e = std::max(e, std::abs(static_cast<double>(x[c]) - tab_.u(c - 1, y0_ + jl)));
    }
    return e;
  }

  // Copies the block's rows of x (without ghosts) to out[0 .. ny*n).
  void copy_x(double* out) {
    for (long jl = 0; jl < ny_; ++jl) std::copy(row(x_.get(), jl) + 1, row(x_.get(), jl) + 1 + n_, out + jl * n_);
  }

 private:
  // A thread's rows for the sweep: the copied edge rows (old r and p of y0-2, y0-1, y1, y1+1) and the two rings
  // of three rows (row y in slot y mod 3). 14 rows of a few kB, allocated once per thread count; ghost columns
  // stay zero.
  struct Scratch {
    explicit Scratch(long s) : s(s), buf(14 * s, T(0)) {}
    long s;
    std::vector<T> buf;
    T* edge_r(int k) { return buf.data() + k * s; }
    T* edge_p(int k) { return buf.data() + (4 + k) * s; }
    T* ring_p(long y) { return buf.data() + (8 + (y + 3) % 3) * s; }  // y >= -3
    T* ring_r(long y) { return buf.data() + (11 + (y + 3) % 3) * s; }
  };

  // Σ_c u_c (A u)_c over one row, with the rows above and below.
  double row_dot_stencil(const T* __restrict up, const T* __restrict u, const T* __restrict dn) const {
    double s = 0;
#pragma omp simd reduction(+ : s)
    for (long c = 1; c <= n_; ++c)
      s += static_cast<double>(u[c]) * static_cast<double>(five_point_rows(u, up, dn, c));
    return s;
  }

  SweepDots sweep_rows(long y0, long y1, T a, T b, Scratch& sc) {
    // Old r and p of row y: the thread's own rows in place (not yet overwritten when read), the others' copies.
    auto old_r = [&](long y) -> const T* {
      return y < y0 ? sc.edge_r(int(y - y0 + 2)) : y >= y1 ? sc.edge_r(int(2 + y - y1)) : row(r_.get(), y);
    };
    auto old_p = [&](long y) -> const T* {
      return y < y0 ? sc.edge_p(int(y - y0 + 2)) : y >= y1 ? sc.edge_p(int(2 + y - y1)) : row(p_.get(), y);
    };
    auto in_grid = [&](long y) { return y0_ + y >= 0 && y0_ + y < n_; };
    double rr = 0, rar = 0;
    for (long y = y0 - 2; y <= y1 + 1; ++y) {
      // Inside the block all three steps of row y are the thread's own: one loop over the row does them together,
      // so the reads of r, p and x from memory are spread over all the work (three loops after one another leave
      // memory idle during the two that run from cache; at N = 2048 on this project's 2-core VM an iteration
      // took 7.0 ms this way against 7.8 ms with three loops).
      if (y >= y0 + 2 && y < y1) {
        fused_row(y, a, b, sc, rr, rar);
        continue;
      }
      // p_k of row y into the ring; on own rows also into p, in place, with x += α p_k.
      T* __restrict pk = sc.ring_p(y);
      if (y >= y0 && y < y1) {
        const T* __restrict r = row(r_.get(), y);
        T* __restrict p = row(p_.get(), y);
        T* __restrict x = row(x_.get(), y);
#pragma omp simd
        for (long c = 1; c <= n_; ++c) {
          const T v = r[c] + b * p[c];
          pk[c] = v;
          p[c] = v;
          x[c] += a * v;
        }
      } else {
        const T* __restrict ro = old_r(y);
        const T* __restrict po = old_p(y);
#pragma omp simd
        for (long c = 1; c <= n_; ++c) pk[c] = ro[c] + b * po[c];
      }
      // r_{k+1} of row q = y - 1 = r_k - α A p_k into the second ring; on own rows also into r, in place, with
      // its r·r.
      const long q = y - 1;
      if (q >= y0 - 1) {
        T* __restrict rn = sc.ring_r(q);
        const T* __restrict pu = sc.ring_p(q - 1);
        const T* __restrict pc = sc.ring_p(q);
        const T* __restrict pd = sc.ring_p(q + 1);
        if (!in_grid(q)) {
          std::fill_n(rn, s_, T(0));
        } else if (q >= y0 && q < y1) {
          T* __restrict r = row(r_.get(), q);
          double sum = 0;
#pragma omp simd reduction(+ : sum)
          for (long c = 1; c <= n_; ++c) {
            const T v = r[c] - a * five_point_rows(pc, pu, pd, c);
            rn[c] = v;
            r[c] = v;
            sum += static_cast<double>(v) * v;
          }
          rr += sum;
        } else {
          const T* __restrict ro = old_r(q);
#pragma omp simd
          for (long c = 1; c <= n_; ++c) rn[c] = ro[c] - a * five_point_rows(pc, pu, pd, c);
        }
      }
      // r·Ar of row z = y - 2, from the ring of new r.
      const long z = y - 2;
      if (z >= y0 && z < y1) rar += row_dot_stencil(sc.ring_r(z - 1), sc.ring_r(z), sc.ring_r(z + 1));
    }
    return {rr, rar};
  }

  // The three steps of row step y where rows y, y - 1 and y - 2 are all the thread's own and inside the grid: p_k
  // of row y (into the ring and p, x += α p_k), r_{k+1} of row y - 1 (into the ring and r, with r·r), the r·Ar term
  // of row y - 2. Column c of a step needs only column c of the step before in this row (p_k[y][c] for A p_k of
  // row y - 1, r_{k+1}[y - 1][c] for A r_{k+1} of row y - 2) and rows made at earlier row steps.
  void fused_row(long y, T a, T b, Scratch& sc, double& rr, double& rar) {
    T* __restrict p = row(p_.get(), y);
    T* __restrict x = row(x_.get(), y);
    const T* __restrict r = row(r_.get(), y);
    T* __restrict rq = row(r_.get(), y - 1);
    T* __restrict pk = sc.ring_p(y);
    const T* __restrict pc = sc.ring_p(y - 1);
    const T* __restrict pu = sc.ring_p(y - 2);
    T* __restrict rn = sc.ring_r(y - 1);
    const T* __restrict rz = sc.ring_r(y - 2);
    const T* __restrict rzu = sc.ring_r(y - 3);
    double s_rr = 0, s_rar = 0;
#pragma omp simd reduction(+ : s_rr, s_rar)
    for (long c = 1; c <= n_; ++c) {
      const T v = r[c] + b * p[c];
      pk[c] = v;
      p[c] = v;
      x[c] += a * v;
      const T w = rq[c] - a * five_point(T(4), pc[c], pc[c - 1], pc[c + 1], pu[c], v);
      rn[c] = w;
      rq[c] = w;
      s_rr += static_cast<double>(w) * w;
      const T u = rz[c];
      s_rar += static_cast<double>(u) * static_cast<double>(five_point(T(4), u, rz[c - 1], rz[c + 1], rzu[c], w));
    }
    rr += s_rr;
    rar += s_rar;
  }

  // (ny + 4)(n + 2) values per vector; refuses a block whose 5 vectors (3 with fmg) will not fit in memory.
  static long checked_size(long n, long ny, bool fmg) {
    const long size = (ny + 2 * kGhost) * (n + 2);
    hpcgi::require_host_memory("N = " + std::to_string(n) + " (" + std::to_string(ny) + " rows here)",
                               (fmg ? 3.0 : 5.0) * sizeof(T) * static_cast<double>(size));
    return size;
  }

  Grid g_;
  GridTable tab_;
  long n_, y0_, ny_, s_;
  bool fmg_;
  long size_;
  double bb_ = 0;  // local ‖b‖², summed in the first touch
  hpcgi::HugeArray<T> x_, r_, p_, w_, b_;  // common/memory.hpp; p_ and w_ null with fmg
  std::vector<Scratch> scratch_;
};

}  // namespace poisson
