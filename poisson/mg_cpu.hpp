// The CPU level kernels of mg.hpp for the openmp and mpi backends, written once: each level is a block of rows
// [y0, y0 + ny) of its n×n grid (all rows in openmp, a rank's rows in mpi), stored with one ghost row above and
// below and one zero ghost column left and right, loops OpenMP-parallel over rows with the static schedule of
// cpu_block.hpp. Level 0 lives in the CpuBlock of CG: its x is z (allocated here in the CpuBlock's layout), its b
// the CG residual r and its residual the CG vector w (free while z is made). What an MPI backend does between
// the kernels (halo rows, gathering a coarse level) is a MgComm; in one process it does nothing.
#pragma once
#include <omp.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "common/memory.hpp"
#include "poisson/cpu_block.hpp"
#include "poisson/mg.hpp"

namespace poisson {

// Rows [y0, y0 + ny) of an n×n level; whole: every row is held here (a level gathered to every rank, or openmp).
struct LevelRows {
  long n, y0, ny;
  bool whole;
};

template <class T>
struct CpuLevel {
  LevelRows rows;
  long s;         // n + 2
  T e;            // added to the diagonal of the last row and column (mg.hpp)
  T *x, *b, *r;   // row -1 (the ghost row above) of each vector; rows -1 .. ny, columns 0 .. n+1
  T* row(T* v, long jl) const { return v + (jl + 1) * s; }
  long n() const { return rows.n; }
  // Threads only where a level is large enough to pay for their start and barrier: a V-cycle runs about ten
  // loops per level, and on a loaded 2-core machine one barrier of 2 threads can wait a time slice (N = 1024 took
  // 400 ms per iteration with threads on every level, 29 ms with one thread).
  bool threaded() const { return rows.ny * rows.n >= kThreadedPoints; }
  static constexpr long kThreadedPoints = 1L << 16;
};

// Between the kernels of a distributed level: ghost rows -1 and ny of v filled with the neighbours' edge rows;
// a level gathered to every rank: the rows of b each rank restricted, made whole on every rank.
template <class T>
class MgComm {
 public:
  virtual ~MgComm() = default;
  virtual void halo(CpuLevel<T>& lv, T* v) = 0;
  virtual void gather_b(CpuLevel<T>& lv) = 0;
};

template <class T>
class CpuMg final : public MgLevels {
 public:
  // rows[l] for every level of mg_level_sizes(blk's n); rows[0] is the CpuBlock's. comm may be null (one process,
  // every level whole).
  // The coarse levels' x, b, r (level 0 borrows the CpuBlock's) lie in one allocation, in huge pages where the
  // kernel allows (common/memory.hpp), each level first touched by its own loop schedule.
  CpuMg(CpuBlock<T>& blk, T* z_row_minus1, const std::vector<LevelRows>& rows, MgComm<T>* comm)
      : comm_(comm), coarse_(hpcgi::huge_array<T>(static_cast<size_t>(coarse_values(rows)))) {
    const std::vector<double> edge = mg_edge_terms(rows[0].n);
    T* next = coarse_.get();
    for (size_t l = 0; l < rows.size(); ++l) {
      CpuLevel<T> lv{rows[l], rows[l].n + 2, static_cast<T>(edge[l]), nullptr, nullptr, nullptr};
      if (l == 0) {
        lv.x = z_row_minus1;
        lv.b = blk.row(blk.r(), -1);
        lv.r = blk.row(blk.w(), -1);
      } else {
        const long size = (rows[l].ny + 2) * lv.s;
        T* base = next;
        next += 3 * size;
#pragma omp parallel for schedule(static) if (lv.threaded())
        for (long jl = -1; jl <= rows[l].ny; ++jl)
          for (long k = 0; k < 3; ++k) std::fill_n(base + k * size + (jl + 1) * lv.s, lv.s, T(0));
        lv.x = base, lv.b = base + size, lv.r = base + 2 * size;
      }
      lv_.push_back(std::move(lv));
    }
  }

  // Values the coarse levels of `rows` hold (x, b, r with ghosts), for the memory check before they are made.
  static double coarse_values(const std::vector<LevelRows>& rows) {
    double v = 0;
    for (size_t l = 1; l < rows.size(); ++l) v += 3.0 * (rows[l].ny + 2) * static_cast<double>(rows[l].n + 2);
    return v;
  }

  int levels() const override { return static_cast<int>(lv_.size()); }

  void zero(int l) override {
    CpuLevel<T>& lv = lv_[l];
#pragma omp parallel for schedule(static) if (lv.threaded())
    for (long jl = 0; jl < lv.rows.ny; ++jl) std::fill_n(lv.row(lv.x, jl) + 1, lv.rows.n, T(0));
  }

  void smooth(int l, int colour) override {
    CpuLevel<T>& lv = lv_[l];
    if (!lv.rows.whole) comm_->halo(lv, lv.x);
#pragma omp parallel for schedule(static) if (lv.threaded())
    for (long jl = 0; jl < lv.rows.ny; ++jl) colour_row(lv, jl, colour);
  }

  // Both colours in one pass over memory: the second colour of row j - 1 right after the first colour of row j
  // (it needs the new first colour of rows j - 2 .. j), which still reads the old second colour of rows j - 1 and
  // j + 1. Each thread's block of rows (and each rank's) needs the new first colour of the row beyond each of its
  // ends before it can finish its own edge rows: so first every thread makes the first colour of its first and
  // last rows, then (after the halo, on a distributed level) every thread sweeps. The same updates as smooth(l,
  // first) then smooth(l, 1 - first), in an order that gives the same values: the tests compare with serial.
  void smooth_pair(int l, int first) override {
    CpuLevel<T>& lv = lv_[l];
    const int second = 1 - first;
    const long ny = lv.rows.ny;
    const int nt = lv.threaded() ? omp_get_max_threads() : 1;
    if (!lv.rows.whole) comm_->halo(lv, lv.x);
#pragma omp parallel num_threads(nt)
    {
      const auto [y0, y1] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (y1 > y0) colour_row(lv, y0, first);
      if (y1 - 1 > y0) colour_row(lv, y1 - 1, first);
    }
    if (!lv.rows.whole) comm_->halo(lv, lv.x);
#pragma omp parallel num_threads(nt)
    {
      const auto [y0, y1] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      for (long j = y0 + 1; j <= y1 - 2; ++j) {
        colour_row(lv, j, first);
        colour_row(lv, j - 1, second);
      }
      if (y1 - 2 >= y0) colour_row(lv, y1 - 2, second);
      if (y1 - 1 >= y0) colour_row(lv, y1 - 1, second);
    }
  }

  void restrict_residual(int l) override {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    if (!f.rows.whole) comm_->halo(f, f.x);
    const long n = f.rows.n;
#pragma omp parallel for schedule(static) if (f.threaded())
    for (long jl = 0; jl < f.rows.ny; ++jl) {
      const T* __restrict x = f.row(f.x, jl);
      const T* __restrict up = f.row(f.x, jl - 1);
      const T* __restrict dn = f.row(f.x, jl + 1);
      const T* __restrict b = f.row(f.b, jl);
      T* __restrict r = f.row(f.r, jl);
      const T d = 4 + (f.rows.y0 + jl == n - 1 ? f.e : T(0));
#pragma omp simd
      for (long k = 1; k <= n; ++k) r[k] = b[k] - (d * x[k] - x[k - 1] - x[k + 1] - up[k] - dn[k]);
      r[n] -= f.e * x[n];
    }
    if (!f.rows.whole) comm_->halo(f, f.r);
    // Coarse row J sits on fine row 2J + 1: this block makes the coarse rows whose fine row it holds.
    const long j0 = f.rows.y0 / 2, j1 = (f.rows.y0 + f.rows.ny) / 2, nc = c.rows.n;
#pragma omp parallel for schedule(static) if (f.threaded())
    for (long J = j0; J < j1; ++J) {
      const long jf = 2 * J + 1 - f.rows.y0;  // local fine row
      const T* __restrict r0 = f.row(f.r, jf - 1);
      const T* __restrict r1 = f.row(f.r, jf);
      const T* __restrict r2 = f.row(f.r, jf + 1);
      T* __restrict bc = c.row(c.b, J - c.rows.y0);
      for (long C = 1; C <= nc; ++C) {  // padded coarse column C sits on padded fine column 2C
        const long k = 2 * C;
        const T t0 = T(0.5) * r0[k - 1] + r1[k - 1] + T(0.5) * r2[k - 1];
        const T t1 = T(0.5) * r0[k] + r1[k] + T(0.5) * r2[k];
        const T t2 = T(0.5) * r0[k + 1] + r1[k + 1] + T(0.5) * r2[k + 1];
        bc[C] = T(0.5) * t0 + t1 + T(0.5) * t2;
      }
    }
    if (c.rows.whole && !f.rows.whole) comm_->gather_b(c);
  }

  void prolong_add(int l) override { prolong(l, true); }
  void interpolate(int l) override { prolong(l, false); }

  // b_{l+1} = Pᵀ b_l in one pass (read b, write a quarter), the coarse rows as restrict_residual makes them.
  void restrict_rhs(int l) override {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    if (!f.rows.whole) comm_->halo(f, f.b);
    const long j0 = f.rows.y0 / 2, j1 = (f.rows.y0 + f.rows.ny) / 2;
#pragma omp parallel for schedule(static) if (f.threaded())
    for (long J = j0; J < j1; ++J) {
      const long jf = 2 * J + 1 - f.rows.y0;
      restrict_row(f.row(f.b, jf - 1), f.row(f.b, jf), f.row(f.b, jf + 1), c.row(c.b, J - c.rows.y0), c.rows.n);
    }
    if (c.rows.whole && !f.rows.whole) comm_->gather_b(c);
  }

 private:
  // x_l += P x_{l+1} (add) or x_l = P x_{l+1}.
  void prolong(int l, bool add) {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    if (!c.rows.whole) comm_->halo(c, c.x);
    const long n = f.rows.n;
#pragma omp parallel for schedule(static) if (f.threaded())
    for (long jl = 0; jl < f.rows.ny; ++jl) {
      const long j = f.rows.y0 + jl;
      // Fine row j = 2J + 1 takes coarse row J (as half of J and half of J); j = 2J half of rows J - 1 and J.
      const long J = j / 2 - c.rows.y0;
      const T* __restrict ca = c.row(c.x, (j & 1) ? J : J - 1);
      const T* __restrict cb = c.row(c.x, J);
      T* __restrict x = f.row(f.x, jl);
      // Padded fine column k = 2C sits on padded coarse column C; k = 2C + 1 lies between C and C + 1.
      auto value = [&](long k) {
        const long C = k / 2;
        const T a = T(0.5) * (ca[C] + cb[C]);
        return (k & 1) ? T(0.5) * (a + T(0.5) * (ca[C + 1] + cb[C + 1])) : a;
      };
      if (add)
        for (long k = 1; k <= n; ++k) x[k] += value(k);
      else
        for (long k = 1; k <= n; ++k) x[k] = value(k);
    }
  }

 public:

  // The fused halves of a level's V-cycle (mg.hpp), one pass over the level's memory each, with the values of
  // zero, smooth_pair(l, 0), restrict_residual(l) and of prolong_add(l), smooth_pair(l, 1). Each thread walks down
  // its rows [a, e) once, a few rows behind one another: at row step y the first colour of row y, the second of
  // row y - 1, then (presmoothing) the residual of row y - 2 into a ring of three rows and the coarse row whose
  // three fine rows are in the ring, or (postsmoothing) the r·x term of row y - 2. The rows next to another thread's
  // (or rank's) rows wait for it: first every thread makes the first colour of its first and last rows, then the
  // pass, then the rest of its first and last rows (and the coarse rows that need residual rows of a neighbour,
  // from the residual's edge rows stored in r).

  // x = 0, red, black; b_{l+1} = Pᵀ (b - A x). From x = 0 the red update is x = b / a: x is neither zeroed nor
  // read before it is written (a black point's neighbours are all red), and the residual never leaves the cache.
  void presmooth_restrict(int l) override {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    const long ny = f.rows.ny, y0 = f.rows.y0, nc = c.rows.n;
    const bool dist = !f.rows.whole;
    const int nt = f.threaded() ? omp_get_max_threads() : 1;
    ensure_rings(nt);
    // The coarse row centred on local fine row jc (global 2J + 1), from fine residual rows jc - 1, jc, jc + 1.
    auto coarse = [&](long jc, const T* r0, const T* r1, const T* r2) {
      restrict_row(r0, r1, r2, c.row(c.b, (y0 + jc - 1) / 2 - c.rows.y0), nc);
    };
    auto centre = [y0](long jc) { return ((y0 + jc) & 1) == 1; };
#pragma omp parallel num_threads(nt)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) red_from_zero(f, a);
      if (e - 1 > a) red_from_zero(f, e - 1);
    }
    if (dist) comm_->halo(f, f.x);  // red of the neighbours' edge rows (their black is not read)
#pragma omp parallel num_threads(nt)
    {
      const int t = omp_get_thread_num();
      const auto [a, e] = static_rows(ny, t, omp_get_num_threads());
      T* ring = rings_[t].data();
      const long s0 = lv_[0].s;
      for (long y = a; y <= e + 1; ++y) {
        if (y < e && y != a && y != e - 1) red_from_zero(f, y);
        if (y - 1 >= a && y - 1 < e) colour_row(f, y - 1, 1);
        const long q = y - 2;  // its residual: rows q - 1 .. q + 1 are final
        if (q > a && q < e - 1) {
          T* rq = ring + (q % 3) * s0;
          residual_row(f, q, rq);
          if (q <= a + 2 || q >= e - 3) std::copy_n(rq, f.s, f.row(f.r, q));  // for the edge coarse rows
          const long jc = q - 1;
          if (jc >= a + 2 && jc <= e - 3 && centre(jc))
            coarse(jc, ring + ((q - 2) % 3) * s0, ring + ((q - 1) % 3) * s0, rq);
        }
      }
    }
    if (dist) comm_->halo(f, f.x);  // the neighbours' final edge rows
#pragma omp parallel num_threads(nt)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) residual_row(f, a, f.row(f.r, a));
      if (e - 1 > a) residual_row(f, e - 1, f.row(f.r, e - 1));
    }
    if (dist) comm_->halo(f, f.r);
#pragma omp parallel num_threads(nt)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      for (long jc = a; jc < e; ++jc)
        if (centre(jc) && !(jc >= a + 2 && jc <= e - 3))
          coarse(jc, f.row(f.r, jc - 1), f.row(f.r, jc), f.row(f.r, jc + 1));
    }
    if (c.rows.whole && !f.rows.whole) comm_->gather_b(c);
  }

  // x += P x_{l+1}, black, red; on level 0 also the local r·z (b·x) of the result, for dot0(). Only the red points
  // are prolonged: the black update that follows does not read the old black value.
  void prolong_postsmooth(int l) override {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    const long ny = f.rows.ny;
    const bool dist = !f.rows.whole;
    const int nt = f.threaded() ? omp_get_max_threads() : 1;
    if (!c.rows.whole) comm_->halo(c, c.x);
#pragma omp parallel num_threads(nt)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) prolong_red(f, c, a);
      if (e - 1 > a) prolong_red(f, c, e - 1);
    }
    if (dist) comm_->halo(f, f.x);
    double dot = 0;
#pragma omp parallel num_threads(nt) reduction(+ : dot)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      for (long y = a; y <= e + 1; ++y) {
        if (y < e && y != a && y != e - 1) prolong_red(f, c, y);
        if (y - 1 >= a && y - 1 < e) colour_row(f, y - 1, 1);
        const long q = y - 2;
        if (q > a && q < e - 1) {
          colour_row(f, q, 0);
          if (l == 0) dot += row_dot(f, q);
        }
      }
    }
    if (dist) comm_->halo(f, f.x);
#pragma omp parallel num_threads(nt) reduction(+ : dot)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) {
        colour_row(f, a, 0);
        if (l == 0) dot += row_dot(f, a);
      }
      if (e - 1 > a) {
        colour_row(f, e - 1, 0);
        if (l == 0) dot += row_dot(f, e - 1);
      }
    }
    if (l == 0) dot0_ = dot;
  }

  // The local b·x of level 0 after the last prolong_postsmooth(0) (r·z of the V-cycle; levels() > 1).
  double dot0() const { return dot0_; }

 private:
  // The red points of local row jl from x = 0: x = b / a (the same value as colour_row with zero neighbours).
  static void red_from_zero(CpuLevel<T>& lv, long jl) {
    const long n = lv.rows.n;
    T* __restrict x = lv.row(lv.x, jl);
    const T* __restrict b = lv.row(lv.b, jl);
    const T d = 4 + (lv.rows.y0 + jl == n - 1 ? lv.e : T(0)), inv = 1 / d;
    long c = 1 + ((lv.rows.y0 + jl) & 1);
    for (; c < n; c += 2) x[c] = b[c] * inv;
    if (c == n) x[c] = b[c] / (d + lv.e);
  }

  // r = b - A x on local row jl (padded, ghost columns zero).
  static void residual_row(const CpuLevel<T>& f, long jl, T* __restrict r) {
    const long n = f.rows.n;
    const T* __restrict x = f.row(f.x, jl);
    const T* __restrict up = f.row(f.x, jl - 1);
    const T* __restrict dn = f.row(f.x, jl + 1);
    const T* __restrict b = f.row(f.b, jl);
    const T d = 4 + (f.rows.y0 + jl == n - 1 ? f.e : T(0));
#pragma omp simd
    for (long k = 1; k <= n; ++k) r[k] = b[k] - (d * x[k] - x[k - 1] - x[k + 1] - up[k] - dn[k]);
    r[n] -= f.e * x[n];
    r[0] = r[n + 1] = 0;
  }

  // Coarse row bc = Pᵀ of fine residual rows r0, r1, r2 (padded coarse column C sits on padded fine column 2C).
  static void restrict_row(const T* __restrict r0, const T* __restrict r1, const T* __restrict r2,
                           T* __restrict bc, long nc) {
    for (long C = 1; C <= nc; ++C) {
      const long k = 2 * C;
      const T t0 = T(0.5) * r0[k - 1] + r1[k - 1] + T(0.5) * r2[k - 1];
      const T t1 = T(0.5) * r0[k] + r1[k] + T(0.5) * r2[k];
      const T t2 = T(0.5) * r0[k + 1] + r1[k + 1] + T(0.5) * r2[k + 1];
      bc[C] = T(0.5) * t0 + t1 + T(0.5) * t2;
    }
  }

  // x += P x_c on the red points of local fine row jl (those all have padded columns of one parity).
  static void prolong_red(CpuLevel<T>& f, const CpuLevel<T>& c, long jl) {
    const long n = f.rows.n, j = f.rows.y0 + jl;
    const long J = j / 2 - c.rows.y0;
    const T* __restrict ca = c.row(c.x, (j & 1) ? J : J - 1);
    const T* __restrict cb = c.row(c.x, J);
    T* __restrict x = f.row(f.x, jl);
    const long k0 = 1 + (j & 1);
    if (k0 & 1) {
      for (long k = k0; k <= n; k += 2) {
        const long C = k / 2;
        const T a = T(0.5) * (ca[C] + cb[C]);
        x[k] += T(0.5) * (a + T(0.5) * (ca[C + 1] + cb[C + 1]));
      }
    } else {
      for (long k = k0; k <= n; k += 2) {
        const long C = k / 2;
        x[k] += T(0.5) * (ca[C] + cb[C]);
      }
    }
  }

  static double row_dot(const CpuLevel<T>& f, long jl) {
    const T* __restrict x = f.row(f.x, jl);
    const T* __restrict b = f.row(f.b, jl);
    const long n = f.rows.n;
    double s = 0;
#pragma omp simd reduction(+ : s)
    for (long k = 1; k <= n; ++k) s += static_cast<double>(b[k]) * x[k];
    return s;
  }

  // One ring of three padded rows of level 0 per thread, for the residual rows of presmooth_restrict.
  void ensure_rings(int nt) {
    if (static_cast<int>(rings_.size()) < nt) rings_.resize(nt, std::vector<T>(3 * lv_[0].s, T(0)));
  }

  // Gauss-Seidel on the points of one colour of local row jl: point i (padded c = i + 1) has colour (i + j) mod 2;
  // the diagonal is 4, plus e on the last row and on the last column.
  static void colour_row(CpuLevel<T>& lv, long jl, int colour) {
    const long n = lv.rows.n;
    T* __restrict x = lv.row(lv.x, jl);
    const T* __restrict up = lv.row(lv.x, jl - 1);
    const T* __restrict dn = lv.row(lv.x, jl + 1);
    const T* __restrict b = lv.row(lv.b, jl);
    const T d = 4 + (lv.rows.y0 + jl == n - 1 ? lv.e : T(0)), inv = 1 / d;
    long c = 1 + ((colour + lv.rows.y0 + jl) & 1);
    for (; c < n; c += 2) x[c] = (b[c] + x[c - 1] + x[c + 1] + up[c] + dn[c]) * inv;
    if (c == n) x[c] = (b[c] + x[c - 1] + x[c + 1] + up[c] + dn[c]) / (d + lv.e);
  }

  std::vector<CpuLevel<T>> lv_;
  MgComm<T>* comm_;
  hpcgi::HugeArray<T> coarse_;
  std::vector<std::vector<T>> rings_;
  double dot0_ = 0;
};

// The fine-grid part of preconditioned CG for a CpuBlock: z in the block's layout and the hierarchy. The dots
// are local to the block (the mpi backend reduces them).
template <class T>
class CpuPcg {
 public:
  CpuPcg(CpuBlock<T>& blk, const std::vector<LevelRows>& rows, MgComm<T>* comm)
      : blk_(blk), size_(checked_size(blk, rows)), z_(hpcgi::huge_array<T>(size_)) {
    const long s = blk.stride();
#pragma omp parallel for schedule(static)
    for (long jl = -CpuBlock<T>::kGhost; jl < blk.rows() + CpuBlock<T>::kGhost; ++jl)
      std::fill_n(blk.row(z_.get(), jl), s, T(0));
    mg_ = std::make_unique<CpuMg<T>>(blk, blk.row(z_.get(), -1), rows, comm);
  }

  // z = M⁻¹ r; returns the local r·z (made by the V-cycle's last pass, prolong_postsmooth(0)).
  double precondition() {
    vcycle(*mg_);
    if (mg_->levels() > 1) return mg_->dot0();
    const long n = blk_.stride() - 2;
    double rz = 0;
#pragma omp parallel for schedule(static) reduction(+ : rz)
    for (long jl = 0; jl < blk_.rows(); ++jl) {
      const T* __restrict r = blk_.row(blk_.r(), jl);
      const T* __restrict z = blk_.row(z_.get(), jl);
#pragma omp simd reduction(+ : rz)
      for (long c = 1; c <= n; ++c) rz += static_cast<double>(r[c]) * z[c];
    }
    return rz;
  }

  // r = x on the block's rows (global row y0 + jl), z = M⁻¹ r; returns the local y·z.
  double apply_dot(const Preconditioned::GridFn& x, const Preconditioned::GridFn& y, long y0) {
    const long n = blk_.stride() - 2;
    for (long jl = 0; jl < blk_.rows(); ++jl)
      for (long c = 1; c <= n; ++c) blk_.row(blk_.r(), jl)[c] = static_cast<T>(x(c - 1, y0 + jl));
    vcycle(*mg_);
    double s = 0;
    for (long jl = 0; jl < blk_.rows(); ++jl)
      for (long c = 1; c <= n; ++c) s += static_cast<double>(blk_.row(z_.get(), jl)[c]) * y(c - 1, y0 + jl);
    return s;
  }

  // p = z + βp, returning the local p·Ap, in one pass: Ap is not stored (calc_ur_p recomputes it from p). Each
  // thread first makes p of its first and last rows, then (after halo(), which fills p's ghost rows on a
  // distributed block) the rest of its rows and p·Ap a row behind. Reads z and p, writes p: 3 vectors of N².
  template <class Halo>
  double calc_p_pw(double beta, Halo&& halo) {
    const T b = static_cast<T>(beta);
    const long ny = blk_.rows();
    auto p_row = [&](long jl) {
      T* __restrict p = blk_.row(blk_.p(), jl);
      const T* __restrict z = blk_.row(z_.get(), jl);
      const long n = blk_.stride() - 2;
#pragma omp simd
      for (long c = 1; c <= n; ++c) p[c] = z[c] + b * p[c];
    };
#pragma omp parallel
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) p_row(a);
      if (e - 1 > a) p_row(e - 1);
    }
    halo();
    double pw = 0;
#pragma omp parallel reduction(+ : pw)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      const long n = blk_.stride() - 2;
      for (long y = a; y <= e; ++y) {
        if (y < e && y != a && y != e - 1) p_row(y);
        const long q = y - 1;
        if (q < a || q >= e) continue;
        const T *pc = blk_.row(blk_.p(), q), *pu = blk_.row(blk_.p(), q - 1), *pd = blk_.row(blk_.p(), q + 1);
        double sum = 0;
#pragma omp simd reduction(+ : sum)
        for (long c = 1; c <= n; ++c) {
          const T v = 4 * pc[c] - pc[c - 1] - pc[c + 1] - pu[c] - pd[c];
          sum += static_cast<double>(pc[c]) * v;
        }
        pw += sum;
      }
    }
    return pw;
  }

  // x += αp, r -= α Ap with Ap recomputed from p (whose ghost rows calc_p_pw filled); returns the local r·r.
  // Reads x, p, r, writes x, r: 5 vectors of N².
  double calc_ur_p(double alpha) {
    const T a = static_cast<T>(alpha);
    const long n = blk_.stride() - 2;
    double rr = 0;
#pragma omp parallel for schedule(static) reduction(+ : rr)
    for (long jl = 0; jl < blk_.rows(); ++jl) {
      T* __restrict x = blk_.row(blk_.x(), jl);
      T* __restrict r = blk_.row(blk_.r(), jl);
      const T *pc = blk_.row(blk_.p(), jl), *pu = blk_.row(blk_.p(), jl - 1), *pd = blk_.row(blk_.p(), jl + 1);
      double sum = 0;
#pragma omp simd reduction(+ : sum)
      for (long c = 1; c <= n; ++c) {
        x[c] += a * pc[c];
        const T w = 4 * pc[c] - pc[c - 1] - pc[c + 1] - pu[c] - pd[c];
        const T rn = r[c] - a * w;
        r[c] = rn;
        sum += static_cast<double>(rn) * rn;
      }
      rr += sum;
    }
    return rr;
  }

  // --method fmg: z ≈ A⁻¹ r by the full-multigrid F-cycle (full; mg.hpp fmg, r = b after init) or by one
  // vcycle_solve from z = 0.
  void solve_cycle(bool full) { full ? fmg(*mg_) : vcycle_solve(*mg_, 0, true); }

  // x += z, r -= A z after the F-cycle or a V-cycle (halo() fills z's ghost rows on a distributed block); returns
  // the local r·r. Reads x, z, r, writes x, r: 5 vectors of N².
  template <class Halo>
  double correct(Halo&& halo) {
    halo(z_.get());
    const long n = blk_.stride() - 2;
    double rr = 0;
#pragma omp parallel for schedule(static) reduction(+ : rr)
    for (long jl = 0; jl < blk_.rows(); ++jl) {
      T* __restrict x = blk_.row(blk_.x(), jl);
      T* __restrict r = blk_.row(blk_.r(), jl);
      const T *zc = blk_.row(z_.get(), jl), *zu = blk_.row(z_.get(), jl - 1), *zd = blk_.row(z_.get(), jl + 1);
      double sum = 0;
#pragma omp simd reduction(+ : sum)
      for (long c = 1; c <= n; ++c) {
        x[c] += zc[c];
        const T rn = r[c] - (4 * zc[c] - zc[c - 1] - zc[c + 1] - zu[c] - zd[c]);
        r[c] = rn;
        sum += static_cast<double>(rn) * rn;
      }
      rr += sum;
    }
    return rr;
  }

  void calc_p_z(double beta) {
    const T b = static_cast<T>(beta);
    const long n = blk_.stride() - 2;
#pragma omp parallel for schedule(static)
    for (long jl = 0; jl < blk_.rows(); ++jl) {
      T* __restrict p = blk_.row(blk_.p(), jl);
      const T* __restrict z = blk_.row(z_.get(), jl);
#pragma omp simd
      for (long c = 1; c <= n; ++c) p[c] = z[c] + b * p[c];
    }
  }

 private:
  static long checked_size(CpuBlock<T>& blk, const std::vector<LevelRows>& rows) {
    const long size = (blk.rows() + 2 * CpuBlock<T>::kGhost) * blk.stride();
    hpcgi::require_host_memory("multigrid at N = " + std::to_string(rows[0].n) + " (z and " +
                                   std::to_string(rows.size() - 1) + " coarse levels)",
                               sizeof(T) * (size + CpuMg<T>::coarse_values(rows)));
    return size;
  }
  CpuBlock<T>& blk_;
  long size_;
  hpcgi::HugeArray<T> z_;
  std::unique_ptr<CpuMg<T>> mg_;
};

}  // namespace poisson
