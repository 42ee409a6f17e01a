// The CPU level kernels of mg.hpp for the openmp and mpi backends, written once: each level is a block of rows
// [y0, y0 + ny) of its n×n grid (all rows in openmp, a rank's rows in mpi), stored with one ghost row above and
// below and one zero ghost column left and right (mg_cpu_rows.hpp: the level and the kernels of one row), loops
// OpenMP-parallel over rows with the static schedule of cpu_block.hpp. Level 0 lives in the CpuBlock of CG: its x
// is z (allocated in cpu_pcg.hpp in the CpuBlock's layout), its b the CG residual r and its residual the CG vector
// w (free while z is made). What an MPI backend does between the kernels (halo rows, gathering a coarse level) is a
// MgComm; in one process it does nothing.
#pragma once
#include <omp.h>

#include <algorithm>
#include <vector>

#include "common/memory.hpp"
#include "poisson/backends/cpu_block.hpp"
#include "poisson/methods/mg.hpp"
#include "poisson/backends/mg_cpu_rows.hpp"

namespace poisson {

template <class T>
class CpuMg final : public MgLevels {
 public:
  // rows[l] for every level of mg_level_sizes(n); level 0's x, b and residual r are the caller's (row -1 of each, in
  // the CpuBlock's layout: z, the CG residual and w for the preconditioner; x, b and r of the block itself for
  // --method fmg, where solver is true and the last pass of level 0 sums ‖b - A x‖² instead of b·x, dot0()). comm
  // may be null (one process, every level whole). The coarse levels' x, b, r lie in one allocation, in huge pages
  // where the kernel allows (common/memory.hpp), x and b of each level first touched by its own loop schedule; r is
  // only touched where the fused kernels store residual rows (a few per thread), so it costs no setup.
  CpuMg(T* x0, T* b0, T* r0, const std::vector<LevelRows>& rows, MgComm<T>* comm, bool solver)
      : comm_(comm), solver_(solver), coarse_(hpcgi::huge_array<T>(static_cast<size_t>(coarse_values(rows)))) {
    const std::vector<double> edge = mg_edge_terms(rows[0].n);
    T* next = coarse_.get();
    for (size_t l = 0; l < rows.size(); ++l) {
      CpuLevel<T> lv{rows[l], rows[l].n + 2, static_cast<T>(edge[l]), nullptr, nullptr, nullptr};
      if (l == 0) {
        lv.x = x0, lv.b = b0, lv.r = r0;
      } else {
        const long size = (rows[l].ny + 2) * lv.s;
        T* base = next;
        next += 3 * size;
#pragma omp parallel for schedule(static) if (lv.threaded())
        for (long jl = -1; jl <= rows[l].ny; ++jl)
          for (long k = 0; k < 2; ++k) std::fill_n(base + k * size + (jl + 1) * lv.s, lv.s, T(0));
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
    for (long jl = 0; jl < lv.rows.ny; ++jl) mg_rows::colour_row(lv, jl, colour);
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
      if (y1 > y0) mg_rows::colour_row(lv, y0, first);
      if (y1 - 1 > y0) mg_rows::colour_row(lv, y1 - 1, first);
    }
    if (!lv.rows.whole) comm_->halo(lv, lv.x);
#pragma omp parallel num_threads(nt)
    {
      const auto [y0, y1] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      for (long j = y0 + 1; j <= y1 - 2; ++j) {
        mg_rows::colour_row(lv, j, first);
        mg_rows::colour_row(lv, j - 1, second);
      }
      if (y1 - 2 >= y0) mg_rows::colour_row(lv, y1 - 2, second);
      if (y1 - 1 >= y0) mg_rows::colour_row(lv, y1 - 1, second);
    }
  }

  void restrict_residual(int l) override {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    if (!f.rows.whole) comm_->halo(f, f.x);
#pragma omp parallel for schedule(static) if (f.threaded())
    for (long jl = 0; jl < f.rows.ny; ++jl) mg_rows::residual_row(f, jl, f.row(f.r, jl));
    if (!f.rows.whole) comm_->halo(f, f.r);
    // Coarse row J sits on fine row 2J + 1: this block makes the coarse rows whose fine row it holds.
    const long j0 = f.rows.y0 / 2, j1 = (f.rows.y0 + f.rows.ny) / 2;
#pragma omp parallel for schedule(static) if (f.threaded())
    for (long J = j0; J < j1; ++J) {
      const long jf = 2 * J + 1 - f.rows.y0;  // local fine row
      mg_rows::restrict_row(f.row(f.r, jf - 1), f.row(f.r, jf), f.row(f.r, jf + 1), c.row(c.b, J - c.rows.y0),
                            c.rows.n);
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
      mg_rows::restrict_row(f.row(f.b, jf - 1), f.row(f.b, jf), f.row(f.b, jf + 1), c.row(c.b, J - c.rows.y0),
                            c.rows.n);
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
      const auto [n_, j, ca, cb, x] = mg_rows::prolong_rows(f, c, jl);
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
  void presmooth_restrict(int l) override { smooth_restrict_pass(l, true); }
  // From the current x: red, black; b_{l+1} = Pᵀ (b - A x) (the solver cycle of mg.hpp), in the same one pass.
  void smooth_restrict(int l) override { smooth_restrict_pass(l, false); }

 private:
  void smooth_restrict_pass(int l, bool from_zero) {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    const long ny = f.rows.ny, y0 = f.rows.y0, nc = c.rows.n;
    const bool dist = !f.rows.whole;
    const int nt = f.threaded() ? omp_get_max_threads() : 1;
    ensure_rings(nt);
    // The first colour of a row: red (from zero: x = b / a).
    auto first = [&](long y) { from_zero ? mg_rows::red_from_zero(f, y) : mg_rows::colour_row(f, y, 0); };
    // The coarse row centred on local fine row jc (global 2J + 1), from fine residual rows jc - 1, jc, jc + 1.
    auto coarse = [&](long jc, const T* r0, const T* r1, const T* r2) {
      mg_rows::restrict_row(r0, r1, r2, c.row(c.b, (y0 + jc - 1) / 2 - c.rows.y0), nc);
    };
    auto centre = [y0](long jc) { return ((y0 + jc) & 1) == 1; };
    if (dist && !from_zero) comm_->halo(f, f.x);  // the neighbours' current edge rows, which red reads
#pragma omp parallel num_threads(nt)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) first(a);
      if (e - 1 > a) first(e - 1);
    }
    if (dist) comm_->halo(f, f.x);  // the first colour of the neighbours' edge rows
#pragma omp parallel num_threads(nt)
    {
      const int t = omp_get_thread_num();
      const auto [a, e] = static_rows(ny, t, omp_get_num_threads());
      T* ring = rings_[t].data();
      const long s0 = lv_[0].s;
      for (long y = a; y <= e + 1; ++y) {
        if (y < e && y != a && y != e - 1) first(y);
        if (y - 1 >= a && y - 1 < e) mg_rows::colour_row(f, y - 1, 1);
        const long q = y - 2;  // its residual: rows q - 1 .. q + 1 are final
        if (q > a && q < e - 1) {
          T* rq = ring + (q % 3) * s0;
          mg_rows::residual_row(f, q, rq);
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
      if (e > a) mg_rows::residual_row(f, a, f.row(f.r, a));
      if (e - 1 > a) mg_rows::residual_row(f, e - 1, f.row(f.r, e - 1));
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

 public:
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
      if (e > a) mg_rows::prolong_red(f, c, a);
      if (e - 1 > a) mg_rows::prolong_red(f, c, e - 1);
    }
    if (dist) comm_->halo(f, f.x);
    double dot = 0;
#pragma omp parallel num_threads(nt) reduction(+ : dot)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      for (long y = a; y <= e + 1; ++y) {
        if (y < e && y != a && y != e - 1) mg_rows::prolong_red(f, c, y);
        if (y - 1 >= a && y - 1 < e) mg_rows::colour_row(f, y - 1, 1);
        const long q = y - 2;
        if (q > a && q < e - 1) {
          mg_rows::colour_row(f, q, 0);
          if (l == 0) dot += mg_rows::row_dot(f, q);
        }
      }
    }
    if (dist) comm_->halo(f, f.x);
#pragma omp parallel num_threads(nt) reduction(+ : dot)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) {
        mg_rows::colour_row(f, a, 0);
        if (l == 0) dot += mg_rows::row_dot(f, a);
      }
      if (e - 1 > a) {
        mg_rows::colour_row(f, e - 1, 0);
        if (l == 0) dot += mg_rows::row_dot(f, e - 1);
      }
    }
    if (l == 0) dot0_ = dot;
  }

  // The solver cycle's second half (mg.hpp vcycle_solve): x += P x_{l+1} on every point, red, black, in one pass;
  // on level 0 of the solver (--method fmg) also the local ‖b - A x‖² of the result, for dot0(). Each thread walks
  // down its rows [a, e): at row step y the prolongation of row y + 1, the red of row y, the black of row y - 1 and
  // the residual of row y - 2. A row's red reads the prolonged black points of the rows beside it, and must read
  // them before their black update: so first every thread prolongs its first two and last two rows, then (after
  // the halo, on a distributed level) makes the red of its first and last rows, then (after the halo) the pass,
  // then (after the halo) the residuals of its first and last rows.
  void prolong_smooth(int l) override {
    CpuLevel<T>& f = lv_[l];
    CpuLevel<T>& c = lv_[l + 1];
    const long ny = f.rows.ny;
    const bool dist = !f.rows.whole, residual = l == 0 && solver_;
    const int nt = f.threaded() ? omp_get_max_threads() : 1;
    auto early = [](long y, long a, long e) { return y == a || y == a + 1 || y == e - 2 || y == e - 1; };
    if (!c.rows.whole) comm_->halo(c, c.x);
#pragma omp parallel num_threads(nt)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      for (long y = a; y < e; ++y)
        if (early(y, a, e)) mg_rows::prolong_row(f, c, y);
    }
    if (dist) comm_->halo(f, f.x);
#pragma omp parallel num_threads(nt)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      if (e > a) mg_rows::colour_row(f, a, 0);
      if (e - 1 > a) mg_rows::colour_row(f, e - 1, 0);
    }
    if (dist) comm_->halo(f, f.x);
    double rr = 0;
#pragma omp parallel num_threads(nt) reduction(+ : rr)
    {
      const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
      for (long y = a; y <= e; ++y) {
        if (y + 1 < e && !early(y + 1, a, e)) mg_rows::prolong_row(f, c, y + 1);
        if (y > a && y < e - 1) mg_rows::colour_row(f, y, 0);
        if (y - 1 >= a && y - 1 < e) mg_rows::colour_row(f, y - 1, 1);
        if (residual && y - 2 >= a + 1 && y - 2 <= e - 2) rr += mg_rows::residual_norm_row(f, y - 2);
      }
    }
    if (residual) {
      if (dist) comm_->halo(f, f.x);
#pragma omp parallel num_threads(nt) reduction(+ : rr)
      {
        const auto [a, e] = static_rows(ny, omp_get_thread_num(), omp_get_num_threads());
        if (e > a) rr += mg_rows::residual_norm_row(f, a);
        if (e - 1 > a) rr += mg_rows::residual_norm_row(f, e - 1);
      }
      dot0_ = rr;
    }
  }

  // The local b·x (or, for the solver, ‖b - A x‖²) of level 0 after the last prolong_postsmooth(0) (levels() > 1).
  double dot0() const { return dot0_; }

 private:
  // One ring of three padded rows of level 0 per thread, for the residual rows of presmooth_restrict.
  void ensure_rings(int nt) {
    if (static_cast<int>(rings_.size()) < nt) rings_.resize(nt, std::vector<T>(3 * lv_[0].s, T(0)));
  }

  std::vector<CpuLevel<T>> lv_;
  MgComm<T>* comm_;
  bool solver_;
  hpcgi::HugeArray<T> coarse_;
  std::vector<std::vector<T>> rings_;
  double dot0_ = 0;
};

}  // namespace poisson
