// One sweep of Gauss-Seidel or SOR (Cohen and Greenberg 1985: the classic radiosity solver), written once over the
// layouts and the row-sharing façade of exec.hpp, for every storage of F (ff_matrix.hpp).
//
// Each thread takes the block of rows the façade gives it (serial: all rows; openmp: its static block) and sweeps it
// in patch order, Gauss-Seidel inside the block, Jacobi between blocks: row i of block [b0, b1) takes the new values
// of rows [b0, i) and the old values of every other row,
//   g_i = e_i + ρ_i (Σ_j F_ij x_j + Σ_{b0 <= j < i} F_ij (y_j - x_j)),   y_i = (1 - ω) x_i + ω g_i,
// so one thread is the plain sweep in patch order, and more threads give each thread's block the sweep of its own
// rows (the answer and the iteration count depend on the thread count, within the tolerance). y is a second vector
// rather than x itself so that the same pass gives the residual of x, Σ_i (e_i + ρ_i Σ_j F_ij x_j - x_i)², for the
// stopping rule, at no extra pass over F: a dense row of F is read once from memory, four rows at a time by the
// Jacobi step's kernel (sums4), and its segment [b0, i) again from cache.
// With ω = 1, y_i = 0·x_i + g_i = g_i exactly: SOR at ω = 1 is Gauss-Seidel bit for bit.
#pragma once
#include <algorithm>
#include <cstddef>
#include <optional>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/host/csr_kernels.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/core/layout.hpp"
#include "radiosity/solve/host/linalg.hpp"

namespace radiosity {

// The helpers of sor_rows below, each inlined into it (they are its inner loops, split out by what they do).
namespace sor_detail {

// Σ_{b0<=j<i} F_ij δ_j for a dense row from its segment seg = F_i + b0 of m = i - b0 values, from cache (the row
// was just summed against x); dc: the block's changes y - x, one array per channel.
template <class Val, int C, class T>
[[gnu::always_inline]] inline void segment(const typename Val::stored* seg, size_t m, T* const (&dc)[3],
                                           T (&sd)[3]) {
  if constexpr (C == 3) {
    T d0 = 0, d1 = 0, d2 = 0;
    const T *e0 = dc[0], *e1 = dc[1], *e2 = dc[2];
#pragma omp simd reduction(+ : d0, d1, d2)
    for (size_t j = 0; j < m; ++j) {
      const T f = Val::get(seg, j);
      d0 += f * e0[j];
      d1 += f * e1[j];
      d2 += f * e2[j];
    }
    sd[0] = d0, sd[1] = d1, sd[2] = d2;
  } else {
    T d0 = 0;
    const T* e0 = dc[0];
#pragma omp simd reduction(+ : d0)
    for (size_t j = 0; j < m; ++j) d0 += T(Val::get(seg, j)) * e0[j];
    sd[0] = d0;
  }
}

// Rows [b0, b1) of a sparse F (csr, compressed, runs), each row's entries once: so against x, sd against the
// changes of the rows before it in the block; update(i, so, sd) makes row i's new value.
template <class Val, int C, class T, class Needed, class Update>
[[gnu::always_inline]] inline void sparse_block(const FFMatrixView& F, const T* const (&xc)[3], T* const (&dc)[3],
                                                size_t b0, size_t b1, const Needed& needed, const Update& update) {
  const auto* data = static_cast<const typename Val::stored*>(F.data);
  for (size_t i = b0; i < b1; ++i) {
    T so[3] = {0, 0, 0}, sd[3] = {0, 0, 0};
    if (needed(i))
      for_each_entry(F, i, [&](size_t k, size_t j) {
        const T f = Val::get(data, k);
        for (int ch = 0; ch < C; ++ch) so[ch] += f * xc[ch][j];
        if (j >= b0 && j < i)
          for (int ch = 0; ch < C; ++ch) sd[ch] += f * dc[ch][j - b0];
      });
    update(i, so, sd);
  }
}

// Rows [b0, b1) of a dense F: four consecutive rows summed against x in one pass (linalg.hpp's sums4, the kernel
// of a Jacobi step, so so is Jacobi's sum to the bit), then each row's segment against the changes, in order. A
// group past b1 repeats its first row in the missing places, as matvec_rows does.
template <class Val, int C, class T, class Needed, class Update>
[[gnu::always_inline]] inline void dense_block(const FFMatrixView& F, size_t n, const T* const (&xc)[3],
                                               T* const (&dc)[3], size_t b0, size_t b1, const Needed& needed,
                                               const Update& update) {
  const auto* data = static_cast<const typename Val::stored*>(F.data);
  for (size_t i0 = b0; i0 < b1; i0 += kGroup) {
    const size_t rows_here = std::min(kGroup, b1 - i0);
    const typename Val::stored* Fr[kGroup];
    for (size_t r = 0; r < kGroup; ++r) Fr[r] = data + (r < rows_here ? i0 + r : i0) * n;
    T s[kGroup][3] = {};
    sums4<Val, C>(Fr, xc[0], xc[1], xc[2], n, s);
    for (size_t r = 0; r < rows_here; ++r) {
      const size_t i = i0 + r;
      T so[3] = {0, 0, 0}, sd[3] = {0, 0, 0};
      if (needed(i)) {
        for (int ch = 0; ch < 3; ++ch) so[ch] = s[r][ch];
        segment<Val, C>(Fr[r] + b0, i - b0, dc, sd);
      }
      update(i, so, sd);
    }
  }
}

}  // namespace sor_detail

// Rows [b0, b1) of one sweep (see above); returns the residual squares of x over those rows.
template <class Val, class V>
[[gnu::noinline]] Rgb sor_rows(const FFMatrixView& F, const V& x, V& y, const V& rho, const V& e,
                               typename V::value_type omega, size_t b0, size_t b1) {
  using T = typename V::value_type;
  constexpr int C = V::kChannels;
  const size_t n = x.size();
  const T scale = T(F.scale);
  // x one contiguous array per channel (AOS de-interleaved once per sweep into this thread's scratch, as
  // matvec_rows does), and this block's changes y - x so far, one array per channel.
  const T* xc[3] = {x.data(0), x.data(1), x.data(2)};
  static thread_local std::optional<Soa<T>> soa;
  if constexpr (V::kStep != 1) {
    if (!soa || soa->size() != n) soa.emplace(n);
    for (size_t j = 0; j < n; ++j)
      for (int ch = 0; ch < 3; ++ch) (*soa)(j, ch) = x(j, ch);
    for (int ch = 0; ch < 3; ++ch) xc[ch] = soa->data(ch);
  }
  static thread_local std::vector<T> delta;
  const size_t len = b1 - b0;
  delta.assign(3 * len, T(0));
  T* const dc[3] = {delta.data(), delta.data() + len, delta.data() + 2 * len};
  Rgb r2{0, 0, 0};
  auto needed = [&](size_t i) { return !(rho(i, 0) == 0 && rho(i, C - 1) == 0 && (C == 1 || rho(i, 1) == 0)); };
  // Row i's update from its sums so = Σ_j F_ij x_j and sd = Σ_{b0<=j<i} F_ij (y_j - x_j), and its residual.
  auto update = [&](size_t i, const T (&so)[3], const T (&sd)[3]) {
    for (int ch = 0; ch < C; ++ch) {
      const T xi = x(i, ch), r = rho(i, ch) * scale;
      const T g = e(i, ch) + r * (so[ch] + sd[ch]);
      const T yi = (T(1) - omega) * xi + omega * g;
      y(i, ch) = yi;
      dc[ch][i - b0] = yi - xi;
      const double res = double(e(i, ch)) + double(r) * double(so[ch]) - double(xi);
      r2[ch] += res * res;
    }
  };
  if (F.storage != FFStorage::dense)
    sor_detail::sparse_block<Val, C>(F, xc, dc, b0, b1, needed, update);
  else
    sor_detail::dense_block<Val, C>(F, n, xc, dc, b0, b1, needed, update);
  if constexpr (C == 1) r2[1] = r2[2] = r2[0];
  return r2;
}

// One sweep from x into y (y != x) over all rows, each thread its block; returns Σ_i (e - A x)_i² per channel.
template <class Exec, class V>
Rgb sor_sweep(const Exec& ex, const FFMatrixView& F, const V& x, V& y, const V& rho, const V& e,
              typename V::value_type omega) {
  auto run = [&](auto values) {
    using Val = decltype(values);
    return ex.reduce(x.size(), [&](size_t b0, size_t b1) { return sor_rows<Val>(F, x, y, rho, e, omega, b0, b1); });
  };
  switch (F.values) {
    case FFValues::float16: return run(Float16Values{});
    case FFValues::bfloat16: return run(BFloat16Values{});
    case FFValues::float32: break;
  }
  return run(Float32Values{});
}

}  // namespace radiosity
