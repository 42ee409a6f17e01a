// The layout of one CPU multigrid level (mg_cpu.hpp) and the kernels of one row of it, written once for the
// openmp and mpi backends: the red-black Gauss-Seidel row (the smoother), its first half from x = 0, the residual
// row, the full-weighting restriction of three fine rows into one coarse row, the bilinear prolongation onto the
// red points of a fine row, and a row's b·x. Each level is a block of rows [y0, y0 + ny) of its n×n grid, stored
// with one ghost row above and below and one zero ghost column left and right.
#pragma once
#include "poisson/contract/stencil.hpp"

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

// One row of a level: each a small inline template, called inside the OpenMP loops of CpuMg.
namespace mg_rows {

// Gauss-Seidel on the points of one colour of local row jl: point i (padded c = i + 1) has colour (i + j) mod 2;
// the diagonal is 4, plus e on the last row and on the last column.
template <class T>
inline void colour_row(CpuLevel<T>& lv, long jl, int colour) {
  const long n = lv.rows.n;
  T* __restrict x = lv.row(lv.x, jl);
  const T* __restrict up = lv.row(lv.x, jl - 1);
  const T* __restrict dn = lv.row(lv.x, jl + 1);
  const T* __restrict b = lv.row(lv.b, jl);
  const T d = 4 + (lv.rows.y0 + jl == n - 1 ? lv.e : T(0)), inv = 1 / d;
  long c = 1 + ((colour + lv.rows.y0 + jl) & 1);
  for (; c < n; c += 2) x[c] = plus_neighbours(b[c], x[c - 1], x[c + 1], up[c], dn[c]) * inv;
  if (c == n) x[c] = plus_neighbours(b[c], x[c - 1], x[c + 1], up[c], dn[c]) / (d + lv.e);
}

// The red points of local row jl from x = 0: x = b / a (the same value as colour_row with zero neighbours).
template <class T>
inline void red_from_zero(CpuLevel<T>& lv, long jl) {
  const long n = lv.rows.n;
  T* __restrict x = lv.row(lv.x, jl);
  const T* __restrict b = lv.row(lv.b, jl);
  const T d = 4 + (lv.rows.y0 + jl == n - 1 ? lv.e : T(0)), inv = 1 / d;
  long c = 1 + ((lv.rows.y0 + jl) & 1);
  for (; c < n; c += 2) x[c] = b[c] * inv;
  if (c == n) x[c] = b[c] / (d + lv.e);
}

// The rows the 5-point operator reads on local row jl: x there and above and below, b, and the diagonal (4, plus
// the last row's e; the last column adds e again, as the callers do).
template <class T>
struct StencilRows {
  long n;
  const T* x;
  const T* up;
  const T* dn;
  const T* b;
  T d;
};
template <class T>
inline StencilRows<T> stencil_rows(const CpuLevel<T>& f, long jl) {
  const long n = f.rows.n;
  return {n, f.row(f.x, jl), f.row(f.x, jl - 1), f.row(f.x, jl + 1), f.row(f.b, jl),
          T(4 + (f.rows.y0 + jl == n - 1 ? f.e : T(0)))};
}

// r = b - A x on local row jl (padded, ghost columns zero).
template <class T>
inline void residual_row(const CpuLevel<T>& f, long jl, T* __restrict r) {
  const auto [n, x, up, dn, b, d] = stencil_rows(f, jl);  // (the loops' omp simd: no aliasing to rule out)
#pragma omp simd
  for (long k = 1; k <= n; ++k) r[k] = b[k] - five_point(d, x[k], x[k - 1], x[k + 1], up[k], dn[k]);
  r[n] -= f.e * x[n];
  r[0] = r[n + 1] = 0;
}

// ‖b - A x‖² on local row jl, summed in double (the residual of residual_row, not stored).
template <class T>
inline double residual_norm_row(const CpuLevel<T>& f, long jl) {
  const auto [n, x, up, dn, b, d] = stencil_rows(f, jl);  // (the loops' omp simd: no aliasing to rule out)
  double s = 0;
#pragma omp simd reduction(+ : s)
  for (long k = 1; k < n; ++k) {
    const double r = b[k] - five_point(d, x[k], x[k - 1], x[k + 1], up[k], dn[k]);
    s += r * r;
  }
  const double r = b[n] - five_point(T(d + f.e), x[n], x[n - 1], x[n + 1], up[n], dn[n]);
  return s + r * r;
}

// Coarse row bc = Pᵀ of fine residual rows r0, r1, r2 (padded coarse column C sits on padded fine column 2C).
template <class T>
inline void restrict_row(const T* __restrict r0, const T* __restrict r1, const T* __restrict r2,
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
// The rows that prolongation into local fine row jl reads and writes: fine row j = 2J + 1 takes coarse row J (as
// half of J and half of J), j = 2J half of rows J - 1 and J; and the fine row's x.
template <class T>
struct ProlongRows {
  long n, j;
  const T* ca;
  const T* cb;
  T* x;
};
template <class T>
inline ProlongRows<T> prolong_rows(CpuLevel<T>& f, const CpuLevel<T>& c, long jl) {
  const long j = f.rows.y0 + jl, J = j / 2 - c.rows.y0;
  return {f.rows.n, j, c.row(c.x, (j & 1) ? J : J - 1), c.row(c.x, J), f.row(f.x, jl)};
}

template <class T>
inline void prolong_red(CpuLevel<T>& f, const CpuLevel<T>& c, long jl) {
  const auto [n, j, ca, cb, x] = prolong_rows(f, c, jl);
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

// x += P x_c on every point of local fine row jl: fine padded column 2C sits on coarse padded column C, 2C + 1
// halfway between C and C + 1 (the coarse ghost columns are zero).
template <class T>
inline void prolong_row(CpuLevel<T>& f, const CpuLevel<T>& c, long jl) {
  const auto [n, j, ca, cb, x] = prolong_rows(f, c, jl);
  for (long C = 0; 2 * C <= n; ++C) {
    const T t0 = T(0.5) * (ca[C] + cb[C]), t1 = T(0.5) * (ca[C + 1] + cb[C + 1]);
    if (C > 0) x[2 * C] += t0;
    if (2 * C + 1 <= n) x[2 * C + 1] += T(0.5) * (t0 + t1);
  }
}

// b·x on local row jl, summed in double.
template <class T>
inline double row_dot(const CpuLevel<T>& f, long jl) {
  const T* __restrict x = f.row(f.x, jl);
  const T* __restrict b = f.row(f.b, jl);
  const long n = f.rows.n;
  double s = 0;
#pragma omp simd reduction(+ : s)
  for (long k = 1; k <= n; ++k) s += static_cast<double>(b[k]) * x[k];
  return s;
}

}  // namespace mg_rows
}  // namespace poisson
