// The fine-grid part of multigrid-preconditioned CG and of --method fmg for the openmp and mpi backends: z in the
// CpuBlock's layout, the level hierarchy of mg_cpu.hpp, and the fused CG updates that read z.
#pragma once
#include <omp.h>

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/memory.hpp"
#include "poisson/backends/cpu_block.hpp"
#include "poisson/contract/stencil.hpp"
#include "poisson/methods/mg.hpp"
#include "poisson/backends/mg_cpu.hpp"

namespace poisson {

// The fine-grid part of preconditioned CG for a CpuBlock: z in the block's layout and the hierarchy, whose level 0
// is z (x), the CG residual (b) and w (its residual). With fmg (--method fmg) there is no z: level 0 is the block's
// own x, b and r, and the cycles improve x in place. The dots are local to the block (the mpi backend reduces them).
template <class T>
class CpuPcg {
 public:
  CpuPcg(CpuBlock<T>& blk, const std::vector<LevelRows>& rows, MgComm<T>* comm, bool fmg)
      : blk_(blk), size_(checked_size(blk, rows, fmg)), z_(fmg ? nullptr : hpcgi::huge_array<T>(size_)) {
    if (fmg) {
      mg_ = std::make_unique<CpuMg<T>>(blk.row(blk.x(), -1), blk.row(blk.b(), -1), blk.row(blk.r(), -1), rows, comm,
                                       true);
      return;
    }
    const long s = blk.stride();
#pragma omp parallel for schedule(static)
    for (long jl = -CpuBlock<T>::kGhost; jl < blk.rows() + CpuBlock<T>::kGhost; ++jl)
      std::fill_n(blk.row(z_.get(), jl), s, T(0));
    mg_ = std::make_unique<CpuMg<T>>(blk.row(z_.get(), -1), blk.row(blk.r(), -1), blk.row(blk.w(), -1), rows, comm,
                                     false);
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
    if (!z_) throw std::logic_error("apply_dot needs the preconditioner's z (--precond mg), not --method fmg");
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
          const T v = five_point_rows(pc, pu, pd, c);
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
        const T w = five_point_rows(pc, pu, pd, c);
        const T rn = r[c] - a * w;
        r[c] = rn;
        sum += static_cast<double>(rn) * rn;
      }
      rr += sum;
    }
    return rr;
  }

  // --method fmg: x improved in place by the full-multigrid F-cycle (full; mg.hpp fmg, from x = 0) or by one
  // solver V-cycle (mg.hpp vcycle_solve); returns the local ‖b - A x‖² of the new x (summed in the cycle's last
  // pass, mg_cpu.hpp; with one level, N = 1, from x directly).
  double solve_cycle(bool full) {
    full ? fmg(*mg_) : vcycle_solve(*mg_, 0, false);
    return mg_->levels() > 1 ? mg_->dot0() : blk_.true_residual2();
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
  static long checked_size(CpuBlock<T>& blk, const std::vector<LevelRows>& rows, bool fmg) {
    const long size = (blk.rows() + 2 * CpuBlock<T>::kGhost) * blk.stride();
    hpcgi::require_host_memory("multigrid at N = " + std::to_string(rows[0].n) + " (" + (fmg ? "" : "z and ") +
                                   std::to_string(rows.size() - 1) + " coarse levels)",
                               sizeof(T) * ((fmg ? 0 : size) + CpuMg<T>::coarse_values(rows)));
    return size;
  }
  CpuBlock<T>& blk_;
  long size_;
  hpcgi::HugeArray<T> z_;
  std::unique_ptr<CpuMg<T>> mg_;
};

}  // namespace poisson
