// The product y = a·x + c·ρ ⊙ (F x) + d·e for a sparse F (ff_matrix.hpp: csr, compressed), all channels in one pass
// over F's entries, rows shared out between threads by their entries (not their count), written once for both
// column codes (int32 columns, uint16 steps) and every value type (float32, float16, bfloat16).
//
// What sets the speed: an entry is its value and its column (8 bytes in csr float32, 4 in compressed 16-bit) and
// one gather of x_j in three channels. So x is copied once per product into this thread's scratch as one float4
// record {r, g, b, 0} per patch (16 bytes, room3's 9680 patches in 155 KB: L2), from AOS and SOA alike: one 128-bit
// load gathers x_j's three channels, one fused multiply-add accumulates them. With AVX-512 four entries share a
// 512-bit register (one vpermps spreads F's values over their 128-bit lanes; 16 entries a pass, four accumulators),
// and F's values and columns are prefetched kSparsePrefetchBytes ahead: the hardware's prefetch alone kept the
// product at half the read sweep. (AVX-512's gathers, three of 16 from SOA x, measured 2.4 x slower than the
// records.) With AVX2 two entries share a 256-bit register (entries k and k + 4 of each group of 8: one in-lane
// vpermilps spreads F's values), four accumulators keep four multiply-adds in flight. A row's sum therefore does
// not depend on the layout, the thread count, the rows beside it or the column code: csr and compressed give the
// same bits for the same values, and so do serial and openmp with any threads (for one build: the paths sum in
// different orders).
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <type_traits>
#include <vector>

#include "radiosity/solve/host/runs_kernels.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/core/layout.hpp"
#include "radiosity/solve/storage/stored_values.hpp"

namespace radiosity {

// The columns of a row's entries, read in order from the row's first entry k0: csr's int32 columns, or compressed's
// steps summed from -1.
struct Int32Cols {
  const int32_t* col;
  struct Cursor {
    const int32_t* col;
    size_t next(size_t k) { return size_t(col[k]); }
    const void* at(size_t k) const { return col + k; }  // entry k's column, for the prefetch
  };
  Cursor row() const { return {col}; }
};
struct Step16Cols {
  const uint16_t* step;
  struct Cursor {
    const uint16_t* step;
    int64_t j = -1;
    size_t next(size_t k) {
      j += step[k];
      return size_t(j);
    }
    const void* at(size_t k) const { return step + k; }  // entry k's step, for the prefetch
  };
  Cursor row() const { return {step}; }
};

// How far ahead of an entry its value and column are asked for (AVX-512 product): on room3 (R = 256, csr float32,
// 2 threads) the product took 5.5 ms without, 3.2 ms at 2 KiB, 2.7-2.9 ms at 4-8 KiB ahead (the hardware's own
// prefetch alone keeps too few lines of the two streams in flight).
inline constexpr size_t kSparsePrefetchBytes = 4096;

// Thread t's rows of [r0, r1) out of nt, by entries: the first row of block t is where the cost
// (row_start[i] - row_start[r0]) + kRowCost·(i - r0) reaches t/nt of the whole, moved up to a multiple of kRowAlign
// rows (from r0) so that no two threads write the same cache line of y.
inline std::pair<size_t, size_t> entry_block(const int64_t* row_start, size_t r0, size_t r1, int t, int nt) {
  auto cost = [&](size_t i) { return double(row_start[i] - row_start[r0]) + double(kRowCost) * double(i - r0); };
  const double total = cost(r1);
  auto first = [&](int u) -> size_t {
    if (u <= 0) return r0;
    if (u >= nt) return r1;
    const double want = total * double(u) / double(nt);
    size_t lo = r0, hi = r1;  // the first i with cost(i) >= want
    while (lo < hi) {
      const size_t mid = lo + (hi - lo) / 2;
      if (cost(mid) < want)
        lo = mid + 1;
      else
        hi = mid;
    }
    return std::min(r1, r0 + round_up(lo - r0, kRowAlign));
  };
  return {first(t), first(t + 1)};
}

// A row's sums s[0..C) over entries [k0, k1), one way per instruction set, each a struct with one static row():
//   PlainSparseSums: a plain loop, every T and channel count;
//   Avx2SparseSums (float, 3 channels): two entries to a 256-bit register (entries k and k + 4 of each group of 8:
//     one in-lane vpermilps spreads F's values), four accumulators keep four multiply-adds in flight;
//   Avx512SparseSums (float, 3 channels): four entries to a 512-bit register (one vpermps spreads F's values over
//     their 128-bit lanes), 16 entries a pass into four accumulators. (Compressed's
//     columns summed four at a time off the chain of adds, or 16 in a vector, measured no faster on room3: the
//     loads and inserts of the records, not that chain, set the pace.)
// SparseSums<Val, T, C> is the best this build has; the tests call the others by name.
struct PlainSparseSums {
  template <class Val, class Cursor, class T, int C>
  static void row(const typename Val::stored* F, Cursor& cur, const T* x4, size_t k0, size_t k1, T (&s)[4]) {
    for (size_t k = k0; k < k1; ++k) {
      const T f = T(Val::get(F, k));
      const size_t j = cur.next(k);
      if constexpr (C == 3) {
        s[0] += f * x4[4 * j];
        s[1] += f * x4[4 * j + 1];
        s[2] += f * x4[4 * j + 2];
      } else {
        s[0] += f * x4[j];
      }
    }
  }
};

#ifdef HPCGI_AVX2_SUMS
struct Avx2SparseSums {
  template <class Val, class Cursor, class T, int C>
  static void row(const typename Val::stored* F, Cursor& cur, const float* x4, size_t k0, size_t k1,
                  float (&s)[4]) {
    static_assert(std::is_same_v<T, float> && C == 3, "the AVX2 sums are float, three channels");
    __m256 acc0 = _mm256_setzero_ps(), acc1 = acc0, acc2 = acc0, acc3 = acc0;
    auto pair = [&](size_t ja, size_t jb) {
      return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(x4 + 4 * ja)), _mm_load_ps(x4 + 4 * jb), 1);
    };
    size_t k = k0;
    for (; k + 8 <= k1; k += 8) {
      const __m256 f = Val::load8(F + k);  // lanes 0-3 entries k..k+3, lanes 4-7 entries k+4..k+7
      size_t j[8];
      for (int q = 0; q < 8; ++q) j[q] = cur.next(k + size_t(q));
      acc0 = _mm256_fmadd_ps(_mm256_permute_ps(f, 0x00), pair(j[0], j[4]), acc0);
      acc1 = _mm256_fmadd_ps(_mm256_permute_ps(f, 0x55), pair(j[1], j[5]), acc1);
      acc2 = _mm256_fmadd_ps(_mm256_permute_ps(f, 0xaa), pair(j[2], j[6]), acc2);
      acc3 = _mm256_fmadd_ps(_mm256_permute_ps(f, 0xff), pair(j[3], j[7]), acc3);
    }
    const __m256 acc = _mm256_add_ps(_mm256_add_ps(acc0, acc1), _mm256_add_ps(acc2, acc3));
    __m128 sum = _mm_add_ps(_mm256_castps256_ps128(acc), _mm256_extractf128_ps(acc, 1));
    for (; k < k1; ++k) sum = _mm_fmadd_ps(_mm_set1_ps(Val::get(F, k)), _mm_load_ps(x4 + 4 * cur.next(k)), sum);
    _mm_storeu_ps(s, sum);
  }
};
#endif

#ifdef HPCGI_AVX512_SUMS
struct Avx512SparseSums {
  template <class Val, class Cursor, class T, int C>
  static void row(const typename Val::stored* F, Cursor& cur, const float* x4, size_t k0, size_t k1,
                  float (&s)[4]) {
    static_assert(std::is_same_v<T, float> && C == 3, "the AVX-512 sums are float, three channels");
    const __m512i spread = _mm512_set_epi32(3, 3, 3, 3, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0);
    const __m512i four = _mm512_set1_epi32(4);
    __m512 acc[4] = {_mm512_setzero_ps(), _mm512_setzero_ps(), _mm512_setzero_ps(), _mm512_setzero_ps()};
    size_t k = k0;
    for (; k + 16 <= k1; k += 16) {
      _mm_prefetch(reinterpret_cast<const char*>(F + k) + kSparsePrefetchBytes, _MM_HINT_T0);
      _mm_prefetch(static_cast<const char*>(cur.at(k)) + kSparsePrefetchBytes, _MM_HINT_T0);
      const __m512 f = Val::load16(F + k, __mmask16(0xffff));
      __m512i lane = spread;
      for (int g = 0; g < 4; ++g, lane = _mm512_add_epi32(lane, four)) {
        const size_t q = k + 4 * size_t(g);
        const size_t jg[4] = {cur.next(q), cur.next(q + 1), cur.next(q + 2), cur.next(q + 3)};
        __m512 r = _mm512_zextps128_ps512(_mm_load_ps(x4 + 4 * jg[0]));
        r = _mm512_insertf32x4(r, _mm_load_ps(x4 + 4 * jg[1]), 1);
        r = _mm512_insertf32x4(r, _mm_load_ps(x4 + 4 * jg[2]), 2);
        r = _mm512_insertf32x4(r, _mm_load_ps(x4 + 4 * jg[3]), 3);
        acc[g] = _mm512_fmadd_ps(_mm512_maskz_permutexvar_ps(0xffff, lane, f), r, acc[g]);  // (maskz: GCC 12 warns on the plain form)
      }
    }
    const __m512 a = _mm512_add_ps(_mm512_add_ps(acc[0], acc[1]), _mm512_add_ps(acc[2], acc[3]));
    alignas(64) float lane4[16];  // (GCC 12's _mm512_extractf32x4_ps warns: -Wmaybe-uninitialized)
    _mm512_store_ps(lane4, a);
    __m128 sum = _mm_add_ps(_mm_add_ps(_mm_load_ps(lane4), _mm_load_ps(lane4 + 4)),
                            _mm_add_ps(_mm_load_ps(lane4 + 8), _mm_load_ps(lane4 + 12)));
    for (; k < k1; ++k) sum = _mm_fmadd_ps(_mm_set1_ps(Val::get(F, k)), _mm_load_ps(x4 + 4 * cur.next(k)), sum);
    _mm_storeu_ps(s, sum);
  }
};
#endif

// The best sums this build has for T and C.
#if defined(HPCGI_AVX512_SUMS)
template <class T, int C>
using SparseSums = std::conditional_t<std::is_same_v<T, float> && C == 3, Avx512SparseSums, PlainSparseSums>;
#elif defined(HPCGI_AVX2_SUMS)
template <class T, int C>
using SparseSums = std::conditional_t<std::is_same_v<T, float> && C == 3, Avx2SparseSums, PlainSparseSums>;
#else
template <class T, int C>
using SparseSums = PlainSparseSums;
#endif

// Rows [i0, i1) of the product, F's entries as Val (stored_values.hpp) and columns as Cols, x4: x as float4 (or
// double4) records, each row's sums by Sums. Out of line, so that every caller runs the same machine code for a row.
template <class Val, class Cols, class V, class Sums = SparseSums<typename V::value_type, V::kChannels>>
[[gnu::noinline]] void sparse_rows(const typename Val::stored* F, Cols cols, const int64_t* start,
                                   const typename V::value_type* x4, const V& x, V& y, const V& rho, const V& e,
                                   typename V::value_type a, typename V::value_type c, typename V::value_type d,
                                   size_t i0, size_t i1) {
  using T = typename V::value_type;
  constexpr int C = V::kChannels;
  for (size_t i = i0; i < i1; ++i) {
    auto cur = cols.row();
    T s[4] = {0, 0, 0, 0};
    Sums::template row<Val, decltype(cur), T, C>(F, cur, x4, size_t(start[i]), size_t(start[i + 1]), s);
    y(i, 0) = a * x(i, 0) + c * rho(i, 0) * s[0] + d * e(i, 0);
    if constexpr (C == 3) {
      y(i, 1) = a * x(i, 1) + c * rho(i, 1) * s[1] + d * e(i, 1);
      y(i, 2) = a * x(i, 2) + c * rho(i, 2) * s[2] + d * e(i, 2);
    }
  }
}

// x as the kernel gathers it: three channels as one record of 4 (the fourth 0), or one channel as it is. Each
// thread its own copy (O(n) per product against F's entries), from AOS, SOA or grey alike.
template <class V>
const typename V::value_type* gather_copy(const V& x) {
  using T = typename V::value_type;
  if constexpr (V::kChannels == 1) {
    return x.data(0);
  } else {
    static thread_local std::optional<AlignedBuffer<T>> buf;
    static thread_local size_t size = 0;
    const size_t n = x.size();
    if (!buf || size != n) {
      buf.emplace(4 * n);
      size = n;
    }
    T* x4 = buf->get();
    for (size_t j = 0; j < n; ++j) {
      x4[4 * j] = x(j, 0);
      x4[4 * j + 1] = x(j, 1);
      x4[4 * j + 2] = x(j, 2);
      x4[4 * j + 3] = 0;
    }
    return x4;
  }
}

// The product on rows [row_begin, row_end) of a csr, compressed or runs matrix (runs: runs_kernels.hpp) whose
// row_start indexes every row (the float16 scale already in c). Exec::each_thread gives each thread its index and count; each takes its block of
// those rows by entries (entry_block). y must not be x.
template <class Val, class Exec, class V>
void sparse_matvec(const Exec& ex, const FFMatrixView& F, const V& x, V& y, const V& rho, const V& e,
                   typename V::value_type a, typename V::value_type c, typename V::value_type d,
                   size_t row_begin = 0, size_t row_end = SIZE_MAX) {
  const size_t r0 = row_begin, r1 = std::min(row_end, x.size());
  if (r1 <= r0) return;
  const auto* data = static_cast<const typename Val::stored*>(F.data);
  ex.each_thread([&](int t, int nt) {
    const auto [i0, i1] = entry_block(F.row_start, r0, r1, t, nt);
    if (i0 >= i1) return;
    if (F.storage == FFStorage::runs) {
      const typename V::value_type* xc[3];
      channel_arrays(x, xc);
      runs_rows<Val>(data, F.run, F.row_start, F.run_start, xc, x, y, rho, e, a, c, d, i0, i1);
      return;
    }
    const auto* x4 = gather_copy(x);
    if (F.storage == FFStorage::csr)
      sparse_rows<Val>(data, Int32Cols{F.col}, F.row_start, x4, x, y, rho, e, a, c, d, i0, i1);
    else
      sparse_rows<Val>(data, Step16Cols{F.step}, F.row_start, x4, x, y, rho, e, a, c, d, i0, i1);
  });
}

}  // namespace radiosity
