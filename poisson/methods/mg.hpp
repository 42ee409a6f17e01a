// The geometric multigrid V-cycle that preconditions CG (--precond mg), written once for every backend; each
// backend supplies the level kernels (MgLevels) on its own memory, as it supplies CG's fused kernels.
//
// Hierarchy: level 0 is the N×N grid, level l+1 has n_{l+1} = n_l / 2 (integer division) points per dimension,
// down to n = 1, so any N >= 1 has one. Coarse point (I, J) sits on fine point (2I+1, 2J+1) (0-based interior
// indices), spacing 2h. For odd n_l = 2m+1 the coarse grid's far boundary is the fine one. For even n_l = 2m the
// coarse grid takes the fine odd-indexed points (m of them), and its last point lies h = H/2, not H, from the
// far boundary (x = 1 and y = 1); a level's far boundary lies δ_l H from its last point, δ_0 = 1 and
// δ_{l+1} = (n_l - 2 n_{l+1} + δ_l) / 2. The coarse operator is the 5-point stencil with the diagonal of the
// last column and of the last row raised by 1/δ_l - 1 (the 1-D Galerkin operator Pᵀ A P has exactly this at
// δ = 1/2: 3 instead of 2), a symmetric change; without it, the re-discretised operator that puts the boundary
// at distance H took 8, 10, 11, 13 iterations at N = 32, 64, 128, 256 against 6 for odd N; with it 6 for all.
//
// Operators, on the h²-scaled system of problem.hpp (4 on the diagonal, -1 per neighbour; on coarse levels the
// diagonal of the last row and column as above) on every level:
//   P  (prolongation): bilinear interpolation, weight 1 at a coarse point, 1/2 between two, 1/4 in a cell's centre;
//   Pᵀ (restriction): its transpose, i.e. 4 × full weighting: with the h² scaling the coarse right-hand side is
//      exactly Pᵀ r (4 h² f restricted = (2h)² f);
//   S  (smoother): one red-black Gauss-Seidel sweep, x_ij = (b_ij + sum of the 4 neighbours) / a_ij on the points of one
//      colour (i + j even: 0, odd: 1, global indices), then the other; before the coarse correction red then
//      black, after it black then red (Sᵀ), so the V-cycle is a symmetric operator and CG stays CG;
//   coarsest level (n = 1): x = b / a, exact (one red "sweep").
// The V-cycle from x = 0 is a fixed linear operator M⁻¹; symmetric by the above, positive definite since the
// smoother converges for this matrix.
#pragma once
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "poisson/contract/kernels.hpp"

namespace poisson {

// n, n/2, n/4, ..., 1.
inline std::vector<long> mg_level_sizes(long n) {
  std::vector<long> s;
  for (long m = n; m >= 1; m /= 2) s.push_back(m);
  return s;
}

// 1/δ_l - 1 of every level (above): what the diagonal of its last row and of its last column gains.
inline std::vector<double> mg_edge_terms(long n) {
  std::vector<double> e;
  double delta = 1;
  for (long m : mg_level_sizes(n)) {
    e.push_back(1.0 / delta - 1.0);
    delta = (static_cast<double>(m - 2 * (m / 2)) + delta) / 2;
  }
  return e;
}

// Values one level of n_l × n_l points holds beyond the finest (x, b and a residual per level): the memory the
// hierarchy adds, as a number of fine-grid vectors ≈ 3 × 1/3 = 1.
inline double mg_extra_values(long n) {
  double v = 0;
  const auto s = mg_level_sizes(n);
  for (size_t l = 1; l < s.size(); ++l) v += 3.0 * static_cast<double>(s[l] + 2) * static_cast<double>(s[l] + 2);
  return v;
}

// The data-movement model of one V-cycle, in vectors of N² (for the record's bandwidth): on each level of n_l²
// points, x = 0 (1), four colour sweeps (read x, half of b, write half of x: 2 each), the residual (read x, b,
// write r: 3), its restriction (read r: 1, write a quarter) and the prolongation (read and write x: 2, read a
// quarter): 15.5 n_l², summed over the levels (about 4/3 of the finest's).
inline int mg_vectors_per_cycle(long n) {
  double v = 0;
  for (long m : mg_level_sizes(n)) v += 15.5 * (static_cast<double>(m) / n) * (static_cast<double>(m) / n);
  return static_cast<int>(v + 0.5);
}

// The same for the fused level kernels of mg_cpu.hpp: presmooth_restrict in one pass (read b, write x, write a
// quarter: 2.25; x = 0 is never stored, the residual never leaves the cache) and prolong_postsmooth in one pass
// (read a quarter, read b and x, write x: 3.25): 5.5 n_l² per level, summed over the levels.
inline int mg_fused_vectors_per_cycle(long n) {
  double v = 0;
  for (long m : mg_level_sizes(n)) v += 5.5 * (static_cast<double>(m) / n) * (static_cast<double>(m) / n);
  return static_cast<int>(v + 0.5);
}

// The level kernels a backend supplies. Level 0's x is the backend's z, its b the CG residual r (read only).
class MgLevels {
 public:
  virtual ~MgLevels() = default;
  virtual int levels() const = 0;
  virtual void zero(int l) = 0;                     // x_l = 0
  virtual void smooth(int l, int colour) = 0;       // Gauss-Seidel on the points of one colour of level l
  // smooth(l, first) then smooth(l, 1 - first); a backend may do both in one pass (mg_cpu.hpp).
  virtual void smooth_pair(int l, int first) {
    smooth(l, first);
    smooth(l, 1 - first);
  }
  virtual void restrict_residual(int l) = 0;        // b_{l+1} = Pᵀ (b_l - A x_l)
  virtual void prolong_add(int l) = 0;              // x_l += P x_{l+1}
  // The two halves of a level's V-cycle; a backend may fuse each into fewer passes over memory (mg_cpu.hpp:
  // one pass each, from x = 0 without reading or zeroing x, the fine residual never stored), with the same values.
  // Before the coarse correction: x_l = 0, red, black, b_{l+1} = Pᵀ (b_l - A x_l).
  virtual void presmooth_restrict(int l) {
    zero(l);
    smooth_pair(l, 0);
    restrict_residual(l);
  }
  // After it: x_l += P x_{l+1}, black, red.
  virtual void prolong_postsmooth(int l) {
    prolong_add(l);
    smooth_pair(l, 1);
  }
  // The solver cycle's halves (vcycle_solve). Before the coarse correction, from the current x_l: red, black,
  // b_{l+1} = Pᵀ (b_l - A x_l) (from x_l = 0 it is presmooth_restrict). After it: x_l += P x_{l+1}, red, black.
  virtual void smooth_restrict(int l) {
    smooth_pair(l, 0);
    restrict_residual(l);
  }
  virtual void prolong_smooth(int l) {
    prolong_add(l);
    smooth_pair(l, 0);
  }
  // The full multigrid's own steps (fmg below); a backend may do each in one pass (mg_cpu.hpp).
  // b_{l+1} = Pᵀ b_l: the right-hand side restricted (x_l is overwritten).
  virtual void restrict_rhs(int l) {
    zero(l);
    restrict_residual(l);
  }
  // x_l = P x_{l+1}: the coarse solution interpolated as the start of level l's V-cycle.
  virtual void interpolate(int l) {
    zero(l);
    prolong_add(l);
  }
};

// x_0 = M⁻¹ b_0: one V(1,1)-cycle from x = 0 on levels l .. levels()-1.
inline void vcycle(MgLevels& k, int l = 0) {
  if (l == k.levels() - 1) {  // n = 1: a x = b, solved by its one red point
    k.zero(l);
    k.smooth(l, 0);
    return;
  }
  k.presmooth_restrict(l);  // x = 0, red, then black, restriction of the residual
  vcycle(k, l + 1);
  k.prolong_postsmooth(l);  // prolongation, black, then red
}

// The V(1,1)-cycle of a multigrid solver (--method fmg) on levels l .. levels()-1, from x_l = 0 (from_zero) or
// from the current x_l: red, black, b_{l+1} = Pᵀ (b_l - A x_l), the same cycle from zero below, x_l += P x_{l+1},
// then red, black again. The smoother and transfers of vcycle, but after the coarse correction red before black,
// not Sᵀ, on every level: with vcycle's symmetric order (which CG needs) a cycle's last red and the next cycle's
// first red follow one another on the fine grid, the second changing nothing, and a pre-smoothing that ends on
// red leaves the residual zero at the coarse points (which are red) before full weighting. As a stationary
// iteration the symmetric cycle reduced ‖r‖ by about 0.25 per cycle, this one by about 0.075 (N = 255, 1023);
// black before red on both sides, or vcycle below this order, gave 0.14-0.2 (measured with serial, N = 255, 1023).
inline void vcycle_solve(MgLevels& k, int l, bool from_zero) {
  if (l == k.levels() - 1) {  // n = 1: exact
    k.zero(l);
    k.smooth(l, 0);
    return;
  }
  from_zero ? k.presmooth_restrict(l) : k.smooth_restrict(l);
  vcycle_solve(k, l + 1, true);
  k.prolong_smooth(l);
}

// x_0 ≈ A⁻¹ b_0 by one full-multigrid F-cycle (--method fmg): b restricted down to the coarsest level, solved
// there exactly, then on each finer level the coarser solution interpolated bilinearly (P) and one solver V-cycle
// from it (vcycle_solve). The V-cycle's smoother and transfers throughout; b_0 is read only, every coarser b and
// every x is overwritten (x_0 is written before it is read). On level l the work is about 4/3 of a V-cycle on
// level l, in all about 4/3 of a fine V-cycle.
inline void fmg(MgLevels& k) {
  const int last = k.levels() - 1;
  for (int l = 0; l < last; ++l) k.restrict_rhs(l);
  k.zero(last);
  k.smooth(last, 0);
  for (int l = last - 1; l >= 0; --l) {
    k.interpolate(l);
    vcycle_solve(k, l, false);
  }
}

// The data-movement model of --method fmg, in vectors of N², for level kernels of these costs on a level of n_l²
// points (each scaled by (n_l / N)²): a solver V-cycle from zero on a level (vcycle_solve from x = 0, the levels
// below it counted apart), one from the current x, and the F-cycle's own transfers (restrict_rhs and interpolate).
struct LevelKernelCosts {
  double cycle_from_zero, cycle_from_x, fmg_transfers;
};
// The fused level kernels of mg_cpu.hpp (openmp, mpi; x_0 the solution itself, updated in place). A cycle from zero:
// presmooth_restrict (read b, write x, write a quarter: 2.25) and prolong_smooth (read a quarter, read b and x,
// write x: 3.25): 5.5. From x: smooth_restrict (read x and b, write x, write a quarter: 3.25) and prolong_smooth
// (3.25): 6.5; on level 0 the last pass also sums ‖b - A x‖² (no extra memory). Transfers: restrict_rhs (read b,
// write a quarter: 1.25), interpolate (read a quarter, write x: 1.25).
inline constexpr LevelKernelCosts kFusedLevelKernels{5.5, 6.5, 2.5};
// MgLevels' own composition of separate kernels (serial, and cuda's mg_cuda.cuh), at mg_vectors_per_cycle's costs:
// x = 0 (1), a colour sweep (2), the residual (3), the restriction (1, and a quarter written), the prolongation (2,
// and a quarter read). From zero: zero, two sweeps, residual, restriction, prolongation, two sweeps: 15.5. From x:
// the same without x = 0: 14.5. Transfers: restrict_rhs (x = 0, residual, restriction: 5.25), interpolate (x = 0,
// prolongation: 3.25): 8.5.
inline constexpr LevelKernelCosts kSeparateLevelKernels{15.5, 14.5, 8.5};
// What the backends that cycle on the correction z (serial, cuda) add to each fmg iteration: [x += z] 3,
// [r = b - A x, r·r] 3 (their vectors_per_iteration counts it too).
inline constexpr int kFmgCorrectionVectors = 6;

// Vectors of N² of one solver V-cycle from x (vcycle_solve on level 0) of the hierarchy, fused level kernels.
inline double mg_solve_vectors_per_cycle(long n) {
  const std::vector<long> s = mg_level_sizes(n);
  double v = s.size() > 1 ? kFusedLevelKernels.cycle_from_x : 0;
  for (size_t l = 1; l < s.size(); ++l)
    v += kFusedLevelKernels.cycle_from_zero * (static_cast<double>(s[l]) / n) * (static_cast<double>(s[l]) / n);
  return v;
}

// Vectors of N² the F-cycle moves on each level, finest first (its total is their sum), with level kernels of
// these costs: on each level l but the coarsest, its transfers and the cycle from x, and the cycles from zero below.
inline std::vector<double> fmg_vectors_per_level(long n, const LevelKernelCosts& c) {
  const std::vector<long> s = mg_level_sizes(n);
  std::vector<double> v(s.size(), 0.0);
  auto w = [n](long m) { return (static_cast<double>(m) / n) * (static_cast<double>(m) / n); };
  for (size_t l = 0; l + 1 < s.size(); ++l) {
    v[l] += (c.fmg_transfers + c.cycle_from_x) * w(s[l]);
    for (size_t m = l + 1; m < s.size(); ++m) v[m] += c.cycle_from_zero * w(s[m]);
  }
  return v;
}

// A value in [-1, 1) for point (i, j) of an n×n grid, the same on every rank and backend (splitmix64 of the index).
inline double grid_random(long n, long i, long j, std::uint64_t seed) {
  std::uint64_t z = static_cast<std::uint64_t>(j * n + i) + seed * 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) / 9007199254740992.0 * 2.0 - 1.0;
}

// |(M⁻¹x)·y − x·(M⁻¹y)| / |(M⁻¹x)·y| for random x, y (seeds 1 and 2): 0 up to rounding for a symmetric M⁻¹.
// Overwrites the backend's r and z (see Preconditioned::apply_dot).
inline double mg_asymmetry(Preconditioned& m, long n) {
  const auto x = [n](long i, long j) { return grid_random(n, i, j, 1); };
  const auto y = [n](long i, long j) { return grid_random(n, i, j, 2); };
  const double a = m.apply_dot(x, y), b = m.apply_dot(y, x);
  return std::abs(a - b) / std::abs(a);
}

}  // namespace poisson
