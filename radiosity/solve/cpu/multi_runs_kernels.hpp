// The product with k right-hand sides, Y_q = a·X_q + c·ρ ⊙ (F X_q) + d·E_q for q < k (relighting: linalg.hpp's
// multi_affine_matvec), for F in a sparse storage (ff_matrix.hpp): runs, csr, compressed. Rows are shared out
// between threads by their entries (csr_kernels.hpp's entry_block), and all k×3 sums of a row come from one pass
// over its entries.
//
// runs: each block of a run's values is loaded and widened once (F16C for float16) and then multiplies the x
// block of every right-hand side and channel. The right-hand sides go in groups of kMultiRunGroup, whose 3·G
// accumulators live in registers: AVX-512 8 (24 of 32 zmm, blocks of 16 values under a _bzhi mask, x by masked
// loads), AVX2 4 (12 of 16 ymm, blocks of 8 under kTailMasks); a row's values (room3: 1800 on average, 7 KiB in
// float32) are read from memory by the first group and from L1 by the others. k = 1 is the one-right-hand-side
// product (runs_rows), so the same bits as affine_matvec; other k sum in blocks of 16 (8) with one accumulator a
// channel, the same bits for any thread count, k and group. Other element types (double: the light basis) and
// builds without AVX2 take a plain loop per right-hand side.
//
// csr and compressed: one pass over a row's entries, each entry's value and column read once for all k×3 sums
// (scalar; x gathered per right-hand side): correct for any storage, not tuned.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "radiosity/solve/cpu/csr_kernels.hpp"
#include "radiosity/solve/cpu/runs_kernels.hpp"
#include "radiosity/solve/layout.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/storage/stored_values.hpp"

namespace radiosity {

#if defined(HPCGI_AVX512_SUMS)
inline constexpr int kMultiRunGroup = 8;
#else
inline constexpr int kMultiRunGroup = 4;
#endif

// Sums of one row's runs for G right-hand sides: s[g][ch] = Σ F_ij · x[g][ch][j] (x[g][ch]: channel ch of the g-th
// right-hand side, one contiguous array).
template <class Val, class T, int G>
inline void multi_run_row(const typename Val::stored* f, const FFRun* u, const FFRun* end, const T* const (&x)[G][3],
                          T (&s)[G][3]) {
#ifdef HPCGI_AVX512_SUMS
  if constexpr (std::is_same_v<T, float>) {
    __m512 acc[G][3];
    for (int g = 0; g < G; ++g)
      for (int ch = 0; ch < 3; ++ch) acc[g][ch] = _mm512_setzero_ps();
    size_t j = 0;
    for (; u < end; ++u) {
      j += u->step;
      const size_t len = u->length;
      prefetch_run(f);
      for (size_t q = 0; q < len; q += 16) {
        const __mmask16 m = __mmask16(_bzhi_u32(0xffffu, uint32_t(std::min<size_t>(len - q, 16))));
        const __m512 fv = Val::load16(f + q, m);
        for (int g = 0; g < G; ++g)
          for (int ch = 0; ch < 3; ++ch)
            acc[g][ch] = _mm512_fmadd_ps(fv, _mm512_maskz_loadu_ps(m, x[g][ch] + j + q), acc[g][ch]);
      }
      f += len;
      j += len;
    }
    for (int g = 0; g < G; ++g)
      for (int ch = 0; ch < 3; ++ch) s[g][ch] = SimdRunSums<Val, 3>::lanes(acc[g][ch]);
    return;
  }
#elif defined(HPCGI_AVX2_SUMS)
  if constexpr (std::is_same_v<T, float>) {
    __m256 acc[G][3];
    for (int g = 0; g < G; ++g)
      for (int ch = 0; ch < 3; ++ch) acc[g][ch] = _mm256_setzero_ps();
    size_t j = 0;
    for (; u < end; ++u) {
      j += u->step;
      const size_t len = u->length;
      prefetch_run(f);
      for (size_t q = 0; q < len; q += 8) {  // F's buffer holds kRunValuePad values past the last: read whole
        const __m256i m = _mm256_load_si256(reinterpret_cast<const __m256i*>(kTailMasks[std::min<size_t>(len - q, 8)]));
        const __m256 fv = _mm256_and_ps(Val::load8(f + q), _mm256_castsi256_ps(m));
        for (int g = 0; g < G; ++g)
          for (int ch = 0; ch < 3; ++ch)
            acc[g][ch] = _mm256_fmadd_ps(fv, _mm256_maskload_ps(x[g][ch] + j + q, m), acc[g][ch]);
      }
      f += len;
      j += len;
    }
    for (int g = 0; g < G; ++g)
      for (int ch = 0; ch < 3; ++ch) {
        const __m128 h = _mm_add_ps(_mm256_castps256_ps128(acc[g][ch]), _mm256_extractf128_ps(acc[g][ch], 1));
        const __m128 w = _mm_add_ps(h, _mm_movehl_ps(h, h));
        s[g][ch] = _mm_cvtss_f32(_mm_add_ss(w, _mm_shuffle_ps(w, w, 1)));
      }
    return;
  }
#endif
  for (int g = 0; g < G; ++g) {  // plain: each right-hand side's pass over the row (its values from L1 after the first)
    PlainRunSums<Val, T, 3> acc;
    const typename Val::stored* fr = f;
    size_t j = 0;
    for (const FFRun* r = u; r < end; ++r) {
      j += r->step;
      acc.add(fr, x[g][0] + j, x[g][1] + j, x[g][2] + j, r->length);
      fr += r->length;
      j += r->length;
    }
    acc.total(s[g]);
  }
}

// Row i for the `count` right-hand sides from q0 on (count <= G): the instance of G = count (its accumulators and
// x pointers for exactly those), Y's row written.
template <class Val, class T, int G = kMultiRunGroup>
inline void multi_runs_row(const FFMatrixView& F, const Soa<T>* X, Soa<T>* Y, const Soa<T>& rho, const Soa<T>* E,
                           size_t q0, size_t count, T a, T c, T d, size_t i) {
  if constexpr (G > 1) {
    if (count < size_t(G)) return multi_runs_row<Val, T, G - 1>(F, X, Y, rho, E, q0, count, a, c, d, i);
  }
  const T* x[G][3];
  for (int g = 0; g < G; ++g)
    for (int ch = 0; ch < 3; ++ch) x[g][ch] = X[q0 + size_t(g)].data(ch);
  T s[G][3];
  multi_run_row<Val, T, G>(static_cast<const typename Val::stored*>(F.data) + F.row_start[i], F.run + F.run_start[i],
                           F.run + F.run_start[i + 1], x, s);
  for (int g = 0; g < G; ++g) {
    const size_t q = q0 + size_t(g);
    for (int ch = 0; ch < 3; ++ch) Y[q](i, ch) = a * X[q](i, ch) + c * rho(i, ch) * s[g][ch] + d * E[q](i, ch);
  }
}

// Rows [i0, i1) of a runs matrix for all k right-hand sides: row by row, its groups of kMultiRunGroup in turn (the
// row's values from memory once, then from L1).
template <class Val, class T>
[[gnu::noinline]] void multi_runs_rows(const FFMatrixView& F, const Soa<T>* X, Soa<T>* Y, const Soa<T>& rho,
                                       const Soa<T>* E, size_t k, T a, T c, T d, size_t i0, size_t i1) {
  for (size_t i = i0; i < i1; ++i)
    for (size_t q0 = 0; q0 < k; q0 += size_t(kMultiRunGroup))
      multi_runs_row<Val, T>(F, X, Y, rho, E, q0, std::min(k - q0, size_t(kMultiRunGroup)), a, c, d, i);
}

// Rows [i0, i1) of a csr or compressed matrix (Cols: csr_kernels.hpp's column cursors) for all k right-hand sides:
// each entry read once, k×3 scalar sums.
template <class Val, class Cols, class T>
[[gnu::noinline]] void multi_sparse_rows(const typename Val::stored* F, Cols cols, const int64_t* start,
                                         const Soa<T>* X, Soa<T>* Y, const Soa<T>& rho, const Soa<T>* E, size_t k,
                                         T a, T c, T d, size_t i0, size_t i1) {
  static thread_local std::vector<T> s;
  s.resize(3 * k);
  for (size_t i = i0; i < i1; ++i) {
    std::fill(s.begin(), s.end(), T(0));
    auto cur = cols.row();
    for (size_t e = size_t(start[i]); e < size_t(start[i + 1]); ++e) {
      const T f = T(Val::get(F, e));
      const size_t j = cur.next(e);
      for (size_t q = 0; q < k; ++q)
        for (int ch = 0; ch < 3; ++ch) s[3 * q + size_t(ch)] += f * X[q](j, ch);
    }
    for (size_t q = 0; q < k; ++q)
      for (int ch = 0; ch < 3; ++ch)
        Y[q](i, ch) = a * X[q](i, ch) + c * rho(i, ch) * s[3 * q + size_t(ch)] + d * E[q](i, ch);
  }
}

// The k-right-hand-side product for a csr, compressed or runs matrix whose row_start indexes every row (the float16
// scale already in c). Rows of patches with reflectivity 0 are empty: their sums are 0, so they get a·X + d·E. Each
// thread takes its block of rows by entries (entry_block). Y must not alias X.
template <class Val, class Exec, class T>
void multi_sparse_matvec(const Exec& ex, const FFMatrixView& F, const std::vector<Soa<T>>& X, std::vector<Soa<T>>& Y,
                         const Soa<T>& rho, const std::vector<Soa<T>>& E, T a, T c, T d) {
  const size_t n = F.n, k = X.size();
  if (n == 0 || k == 0) return;
  const auto* data = static_cast<const typename Val::stored*>(F.data);
  ex.each_thread([&](int t, int nt) {
    const auto [i0, i1] = entry_block(F.row_start, 0, n, t, nt);
    if (i0 >= i1) return;
    if (F.storage == FFStorage::runs) {
      if (k == 1) {  // the one-right-hand-side product itself
        const T* xc[3];
        channel_arrays(X[0], xc);
        runs_rows<Val>(data, F.run, F.row_start, F.run_start, xc, X[0], Y[0], rho, E[0], a, c, d, i0, i1);
        return;
      }
      multi_runs_rows<Val, T>(F, X.data(), Y.data(), rho, E.data(), k, a, c, d, i0, i1);
      return;
    }
    if (F.storage == FFStorage::csr)
      multi_sparse_rows<Val>(data, Int32Cols{F.col}, F.row_start, X.data(), Y.data(), rho, E.data(), k, a, c, d, i0,
                             i1);
    else
      multi_sparse_rows<Val>(data, Step16Cols{F.step}, F.row_start, X.data(), Y.data(), rho, E.data(), k, a, c, d,
                             i0, i1);
  });
}

}  // namespace radiosity
