// The product with k right-hand sides, Y_q = a·X_q + c·ρ ⊙ (F X_q) + d·E_q for q < k (relighting: linalg.hpp's
// multi_affine_matvec), for F in a sparse storage (ff_matrix.hpp): runs, csr, compressed. Rows are shared out
// between threads by their entries (csr_kernels.hpp's entry_block), and a row's k×3 sums come from one pass over its
// entries (the SIMD runs product: one per group of 8 right-hand sides; the plain one: one per right-hand side, the
// row's values from L1 after the first).
//
// runs, float (AVX2/AVX-512 builds): chunked_runs_matvec below. x is transposed once per product into columns of
// W floats (every right-hand side's three channels of patch j side by side), so that one value F_ij multiplies a
// whole column in W/16 zmm and W%16/8 ymm fused multiply-adds with F_ij broadcast, and a row's k×3 sums stay W
// floats in registers (no horizontal sums). The columns go in chunks whose x fits L1, kChunkRows rows at a time.
// Measured on room3 (k = 8, float32, 2 threads, this project's shared VM): a register group of 8 right-hand sides
// over the SOA x read x (930 KB) from L2/L3 for every value: 41 ms; this product 12.5-22 ms (README). Its cost is
// the loop over a row's values, not the multiply-adds or F's bytes: k = 2 costs 15-17 ms of k = 8's 19-22, float16
// as much as float32.
// k = 1 is the one-right-hand-side product (runs_rows): the same bits as affine_matvec. Other element types
// (double: the light basis) and builds without AVX2 take a plain loop (PlainRunSums) per right-hand side, a row's
// values from L1 after the first.
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

// The plain product's right-hand sides a pass over a row (its values from L1 after the first).
inline constexpr int kMultiRunGroup = 4;

// Sums of one row's runs for G right-hand sides: s[g][ch] = Σ F_ij · x[g][ch][j] (x[g][ch]: channel ch of the g-th
// right-hand side, one contiguous array).
template <class Val, class T, int G>
inline void multi_run_row(const typename Val::stored* f, const FFRun* u, const FFRun* end, const T* const (&x)[G][3],
                          T (&s)[G][3]) {
  for (int g = 0; g < G; ++g) {  // each right-hand side's pass over the row (its values from L1 after the first)
    PlainRunSums<Val, T, 3> acc;
    const typename Val::stored* fr = f;
    size_t j = 0;
    for (const FFRun* r = u; r < end; ++r) {
      j += r->step;
      acc.template add<0>(fr, x[g][0] + j, x[g][1] + j, x[g][2] + j, r->length);
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

#ifdef HPCGI_AVX2_SUMS
// The SIMD runs product (float): x transposed once per product into columns of W floats (up to W/3 right-hand sides
// of three channels, the rest 0: W = 8 for k <= 2, 16 for k <= 5, else 24 in groups of 8), so that one value F_ij
// multiplies the whole column j of x in W/16 zmm (AVX-512) and W%16/8 ymm fused multiply-adds, broadcast, and a
// row's k×3 sums are W floats in registers: no horizontal sums. The columns go in chunks of kMultiChunkBytes of x
// (L1), every row of a block of kChunkRows taking its runs' values in the chunk (a run cut where a chunk ends), so
// each x column is loaded from L1 by every row that reads it instead of from L2 or L3 (k = 8: x is 930 KB on room3).
// A row's place in its runs is kept between chunks (RunCursor), its sums in memory (W floats a row and group). The
// sums run in another order than the single product's: not its bits, but the same bits for any thread count.
inline constexpr size_t kMultiChunkBytes = 24 * 1024;

template <int W>
struct ColumnAcc {
#ifdef HPCGI_AVX512_SUMS
  static constexpr int kZ = W / 16;
#else
  static constexpr int kZ = 0;
#endif
  static constexpr int kH = (W - 16 * kZ) / 8;
  // four sets of accumulators (values q, q+1, q+2, q+3) keep four multiply-adds in flight per register
#ifdef HPCGI_AVX512_SUMS
  __m512 z[4][kZ > 0 ? kZ : 1];
#endif
  __m256 h[4][kH > 0 ? kH : 1];
  ColumnAcc() {
    for (int s = 0; s < 4; ++s) {
#ifdef HPCGI_AVX512_SUMS
      for (int u = 0; u < kZ; ++u) z[s][u] = _mm512_setzero_ps();
#endif
      for (int u = 0; u < kH; ++u) h[s][u] = _mm256_setzero_ps();
    }
  }
  template <int S>
  void add(float f, const float* x) {
#ifdef HPCGI_AVX512_SUMS
    if constexpr (kZ > 0) {
      const __m512 b = _mm512_set1_ps(f);
      for (int u = 0; u < kZ; ++u) z[S][u] = _mm512_fmadd_ps(b, _mm512_loadu_ps(x + 16 * u), z[S][u]);
      const __m256 b8 = _mm256_set1_ps(f);
      for (int u = 0; u < kH; ++u) h[S][u] = _mm256_fmadd_ps(b8, _mm256_loadu_ps(x + 16 * kZ + 8 * u), h[S][u]);
      return;
    }
#endif
    const __m256 b = _mm256_set1_ps(f);
    for (int u = 0; u < kH; ++u) h[S][u] = _mm256_fmadd_ps(b, _mm256_loadu_ps(x + 16 * kZ + 8 * u), h[S][u]);
  }
  // The values f[0..count) (stored as Val, contiguous: a row's runs in a chunk) times the columns of x at
  // x + col[p]·W: four at a time, the last 1-3 as one more group with the lanes past count 0, so that the loop runs
  // over the row's values in the chunk with no branch per run or value. That group reads col[count..count+2] (set to
  // 0 by expand_columns) and multiplies x's column 0 by 0: a non-finite x there would make the row NaN, as it
  // would the solve.
  template <class Val>
  void sweep(const typename Val::stored* f, const uint32_t* col, size_t count, const float* x) {
    alignas(16) float t[4];
    size_t p = 0;
    for (; p + 4 <= count; p += 4) {
      const float* g;
      if constexpr (std::is_same_v<Val, Float32Values>) {
        g = f + p;
      } else {
        _mm_store_ps(t, four<Val>(f + p));
        g = t;
      }
      add<0>(g[0], x + size_t(col[p]) * W);
      add<1>(g[1], x + size_t(col[p + 1]) * W);
      add<2>(g[2], x + size_t(col[p + 2]) * W);
      add<3>(g[3], x + size_t(col[p + 3]) * W);
    }
    if (p < count) {
      const __m128i below = _mm_cmpgt_epi32(_mm_set1_epi32(int(count - p)), _mm_setr_epi32(0, 1, 2, 3));
      _mm_store_ps(t, _mm_and_ps(four<Val>(f + p), _mm_castsi128_ps(below)));
      add<0>(t[0], x + size_t(col[p]) * W);
      add<1>(t[1], x + size_t(col[p + 1]) * W);
      add<2>(t[2], x + size_t(col[p + 2]) * W);
    }
  }
  // Four stored values from p as float (F's buffer holds kRunValuePad values past its last).
  template <class Val>
  static __m128 four(const typename Val::stored* p) {
    if constexpr (std::is_same_v<Val, Float32Values>) {
      return _mm_loadu_ps(p);
    } else {
      const __m128i h = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p));
      if constexpr (std::is_same_v<Val, Float16Values>) return _mm_cvtph_ps(h);
      return _mm_castsi128_ps(_mm_slli_epi32(_mm_cvtepu16_epi32(h), 16));  // bfloat16
    }
  }
  // out[0..W) += the four sets' sum
  void flush(float* out) const {
#ifdef HPCGI_AVX512_SUMS
    for (int u = 0; u < kZ; ++u) {
      const __m512 t = _mm512_add_ps(_mm512_add_ps(z[0][u], z[1][u]), _mm512_add_ps(z[2][u], z[3][u]));
      _mm512_storeu_ps(out + 16 * u, _mm512_add_ps(_mm512_loadu_ps(out + 16 * u), t));
    }
#endif
    for (int u = 0; u < kH; ++u) {
      const __m256 t = _mm256_add_ps(_mm256_add_ps(h[0][u], h[1][u]), _mm256_add_ps(h[2][u], h[3][u]));
      float* o = out + 16 * kZ + 8 * u;
      _mm256_storeu_ps(o, _mm256_add_ps(_mm256_loadu_ps(o), t));
    }
  }
};

// Where a row stands in its runs: run r (r == end: the row is done), the values left in it (rem > 0 unless done),
// the column j and value offset v of the next value.
struct RunCursor {
  int64_t r, end, v;
  uint32_t j, rem;
  void settle(const FFRun* run) {  // past runs of length 0 (bridges) and finished runs
    while (r < end && rem == 0)
      if (++r < end) j += run[r].step, rem = run[r].length;
  }
};

// x's k vectors as ng groups of n columns of W floats (ColumnAcc), Xt[(g·n + j)·W + 3·q + ch].
template <int W, class Exec>
void transpose_x(const Exec& ex, const std::vector<Soa<float>>& X, float* Xt, size_t ng) {
  const size_t n = X[0].size(), k = X.size(), G = W / 3;
  ex.rows(n, [&](size_t j0, size_t j1) {
    for (size_t g = 0; g < ng; ++g)
      for (size_t j = j0; j < j1; ++j) {
        float* col = Xt + (g * n + j) * W;
        for (size_t q = 0; q < G; ++q)
          for (int ch = 0; ch < 3; ++ch) col[3 * q + size_t(ch)] = g * G + q < k ? X[g * G + q](j, ch) : 0.0f;
        for (size_t u = 3 * G; u < W; ++u) col[u] = 0;
      }
  });
}

// The columns of the values of a row's runs from u on that lie before column c1, into col[0..count) (count
// returned; u moved past them, a run cut at c1 continuing there), col[count..count+3] = 0. A run's columns are
// written 16 (AVX-512; else 8) at a time whatever its length, so a short run takes one store and no branch on its
// length: col holds the chunk's columns and 16 more.
inline size_t expand_columns(RunCursor& u, const FFRun* run, uint32_t c1, uint32_t* col) {
  size_t count = 0;
  while (u.r < u.end && u.j < c1) {
    const uint32_t len = std::min(u.rem, c1 - u.j);
#ifdef HPCGI_AVX512_SUMS
    const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    for (uint32_t q = 0; q < len; q += 16)
      _mm512_storeu_si512(col + count + q, _mm512_add_epi32(_mm512_set1_epi32(int(u.j + q)), iota));
#else
    const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (uint32_t q = 0; q < len; q += 8)
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(col + count + q),
                          _mm256_add_epi32(_mm256_set1_epi32(int(u.j + q)), iota));
#endif
    count += len;
    u.v += len, u.j += len, u.rem -= len;
    u.settle(run);
  }
  _mm_storeu_si128(reinterpret_cast<__m128i*>(col + count), _mm_setzero_si128());
  return count;
}

// Rows [i0, i1) of the product, all k right-hand sides: kChunkRows rows at a time (their places in their runs and
// their sums stay in L1), the columns in chunks (see kMultiChunkBytes) over those rows.
inline constexpr size_t kChunkRows = 64;

template <class Val, int W>
[[gnu::noinline]] void chunked_runs_rows(const FFMatrixView& F, const float* Xt, size_t ng, const Soa<float>* X,
                                         Soa<float>* Y, const Soa<float>& rho, const Soa<float>* E, size_t k, float a,
                                         float c, float d, size_t i0, size_t i1) {
  const size_t n = F.n, G = W / 3;
  const auto* data = static_cast<const typename Val::stored*>(F.data);
  const size_t chunk = std::max<size_t>(64, kMultiChunkBytes / (W * sizeof(float) * ng) / 16 * 16);
  RunCursor cur[kChunkRows];
  static thread_local AlignedBuffer<float> sums(1);
  static thread_local AlignedBuffer<uint32_t> col(1);
  static thread_local size_t sums_size = 0, col_size = 0;
  if (sums_size < kChunkRows * ng * W) sums = AlignedBuffer<float>(sums_size = kChunkRows * ng * W);
  if (col_size < chunk + 32) col = AlignedBuffer<uint32_t>(col_size = chunk + 32);
  for (size_t b0 = i0; b0 < i1; b0 += kChunkRows) {
    const size_t b1 = std::min(i1, b0 + kChunkRows);
    std::fill(sums.get(), sums.get() + (b1 - b0) * ng * W, 0.0f);
    for (size_t i = b0; i < b1; ++i) {
      RunCursor& u = cur[i - b0];
      u = {F.run_start[i], F.run_start[i + 1], F.row_start[i], 0, 0};
      if (u.r < u.end) u.j = F.run[u.r].step, u.rem = F.run[u.r].length;
      u.settle(F.run);
    }
    for (size_t c0 = 0; c0 < n; c0 += chunk) {
      const uint32_t c1 = uint32_t(std::min(n, c0 + chunk));
      for (size_t i = b0; i < b1; ++i) {
        RunCursor& u = cur[i - b0];
        if (u.r == u.end || u.j >= c1) continue;
        const typename Val::stored* f = data + u.v;
        const size_t count = expand_columns(u, F.run, c1, col.get());
        for (size_t g = 0; g < ng; ++g) {
          ColumnAcc<W> acc;
          acc.template sweep<Val>(f, col.get(), count, Xt + g * n * W);
          acc.flush(sums.get() + ((i - b0) * ng + g) * W);
        }
        // the row's next values, read a chunk later
        _mm_prefetch(reinterpret_cast<const char*>(data + u.v), _MM_HINT_T0);
        _mm_prefetch(reinterpret_cast<const char*>(data + u.v) + kCacheLine, _MM_HINT_T0);
      }
    }
    for (size_t i = b0; i < b1; ++i)
      for (size_t q = 0; q < k; ++q) {
        const float* s = sums.get() + ((i - b0) * ng + q / G) * W + 3 * (q % G);
        for (int ch = 0; ch < 3; ++ch) Y[q](i, ch) = a * X[q](i, ch) + c * rho(i, ch) * s[ch] + d * E[q](i, ch);
      }
  }
}

// The chunked product over every row (k >= 2, float): x transposed, then each thread its block of rows by entries.
template <class Val, int W, class Exec>
void chunked_runs_matvec(const Exec& ex, const FFMatrixView& F, const std::vector<Soa<float>>& X,
                         std::vector<Soa<float>>& Y, const Soa<float>& rho, const std::vector<Soa<float>>& E, float a,
                         float c, float d) {
  const size_t n = F.n, k = X.size(), ng = (k + W / 3 - 1) / (W / 3);
  static thread_local AlignedBuffer<float> xt(1);
  static thread_local size_t xt_size = 0;
  if (xt_size < (ng * n + 32) * W) xt = AlignedBuffer<float>(xt_size = (ng * n + 32) * W);
  std::fill(xt.get() + ng * n * W, xt.get() + (ng * n + 32) * W, 0.0f);  // the columns a last group reads past x
  const float* const Xt = xt.get();  // this thread's buffer: the name xt in the threads below would be theirs
  transpose_x<W>(ex, X, xt.get(), ng);
  ex.each_thread([&](int t, int nt) {
    const auto [i0, i1] = entry_block(F.row_start, 0, n, t, nt);
    if (i0 < i1) chunked_runs_rows<Val, W>(F, Xt, ng, X.data(), Y.data(), rho, E.data(), k, a, c, d, i0, i1);
  });
}
#endif

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
#ifdef HPCGI_AVX2_SUMS
  if constexpr (std::is_same_v<T, float>) {
    if (F.storage == FFStorage::runs && k >= 2) {
      if (k <= 2) return chunked_runs_matvec<Val, 8>(ex, F, X, Y, rho, E, a, c, d);
      if (k <= 5) return chunked_runs_matvec<Val, 16>(ex, F, X, Y, rho, E, a, c, d);
      return chunked_runs_matvec<Val, 24>(ex, F, X, Y, rho, E, a, c, d);
    }
  }
#endif
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
