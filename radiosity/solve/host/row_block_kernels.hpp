// The product with k right-hand sides over F's row blocks (row_blocks.hpp): Y_q = a·X_q + c·ρ ⊙ (F X_q) + d·E_q for
// q < k (linalg.hpp's multi_affine_matvec). The right-hand sides go in groups of up to kBlockGroup, whose C = 3 ×
// (right-hand sides) channels are transposed once per product into x columns of C values (xt[j·C + ch]). A block's
// sums are C vectors of its 16 rows, in registers for the whole block: each column of the block is one vector of F
// (16 floats; for double, two halves of 8, each half a pass over the block's columns) times x_j's C values, each
// broadcast from memory into its fused multiply-add. No horizontal sums, no column indices (a segment's columns are
// consecutive), F's bytes read once per block for every group (the later groups from L2).
//
// Measured on room3.xml's F at R = 256 (9680 patches), 2 threads, this project's 2-core EPYC VM: `make bench`
// (bench-relight, commit 573d0ed) k = 8 in 3.71 ms (float32) and 3.32 ms (float16), 1.33-1.53 and 1.41-1.82 times
// the one-right-hand-side runs product timed in turns with it (docs/design-notes.md, "Sparse F for the relighting"). The
// multiply-adds, not F's bytes, set the pace: a scratch program's blocks over all 9680 rows, 1.67 M columns × 24 /
// 2 cores / 2 a cycle, are 3.8 ms at 2.6 GHz. In that program F's values asked for 4 KiB ahead (kSparsePrefetchBytes)
// took k = 8 in float32 from 6.0 ms (no prefetch) to 3.7-3.9 ms; 2 KiB: 4.3-4.6 ms, 8 KiB: 4.2 ms.
//
// The sums may run in another order than the one-right-hand-side products' (not necessarily their bits); a row's
// sums do not depend on the thread that takes its block, so the bits are the same for any thread count. Builds
// without AVX-512 run the same loop over arrays of 16 lanes (correct; as fast as the compiler makes it).
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "radiosity/solve/host/csr_kernels.hpp"
#include "radiosity/solve/core/layout.hpp"
#include "radiosity/solve/storage/row_blocks.hpp"
#include "radiosity/solve/storage/stored_values.hpp"

namespace radiosity {

// Right-hand sides a pass over a block: 8 of three channels are 24 sums of 16 rows, 24 of the 32 AVX-512 registers.
inline constexpr size_t kBlockGroup = 8;

// A block's rows as vectors: kParts parts of kWidth rows (float: one of 16; double: two of 8), and the operations
// the kernel needs on them.
template <class Val, class T>
struct BlockLanes;

#ifdef HPCGI_AVX512_SUMS
template <class Val>
struct BlockLanes<Val, float> {
  static constexpr int kParts = 1, kWidth = 16;
  using V = __m512;
  static V zero() { return _mm512_setzero_ps(); }
  static V load(const typename Val::stored* col, int) { return Val::load16(col, 0xffff); }
  static V fma(V f, const float* x, V acc) { return _mm512_fmadd_ps(f, _mm512_set1_ps(*x), acc); }
  // y[0..rows) = a·x + c·ρ·s + d·e
  static void store(float* y, const float* x, const float* rho, const float* e, V s, float a, float c, float d,
                    size_t rows) {
    const __mmask16 m = rows >= 16 ? __mmask16(0xffff) : __mmask16((1u << rows) - 1);
    const V t = _mm512_fmadd_ps(_mm512_set1_ps(a), _mm512_maskz_loadu_ps(m, x),
                                _mm512_mul_ps(_mm512_set1_ps(d), _mm512_maskz_loadu_ps(m, e)));
    _mm512_mask_storeu_ps(y, m, _mm512_fmadd_ps(_mm512_mul_ps(_mm512_set1_ps(c), _mm512_maskz_loadu_ps(m, rho)), s, t));
  }
};
template <class Val>
struct BlockLanes<Val, double> {
  static constexpr int kParts = 2, kWidth = 8;
  using V = __m512d;
  static V zero() { return _mm512_setzero_pd(); }
  static V load(const typename Val::stored* col, int part) {
    return _mm512_maskz_cvtps_pd(0xff, Val::load8(col + 8 * part));  // maskz: GCC 12 warns of the plain one
  }
  static V fma(V f, const double* x, V acc) { return _mm512_fmadd_pd(f, _mm512_set1_pd(*x), acc); }
  static void store(double* y, const double* x, const double* rho, const double* e, V s, double a, double c,
                    double d, size_t rows) {
    const __mmask8 m = rows >= 8 ? __mmask8(0xff) : __mmask8((1u << rows) - 1);
    const V t = _mm512_fmadd_pd(_mm512_set1_pd(a), _mm512_maskz_loadu_pd(m, x),
                                _mm512_mul_pd(_mm512_set1_pd(d), _mm512_maskz_loadu_pd(m, e)));
    _mm512_mask_storeu_pd(y, m, _mm512_fmadd_pd(_mm512_mul_pd(_mm512_set1_pd(c), _mm512_maskz_loadu_pd(m, rho)), s, t));
  }
};
#else
template <class Val, class T>
struct BlockLanes {
  static constexpr int kParts = 1, kWidth = 16;
  struct V {
    T v[16];
  };
  static V zero() { return V{}; }
  static V load(const typename Val::stored* col, int) {
    V f;
    for (int r = 0; r < 16; ++r) f.v[r] = T(Val::get(col, size_t(r)));
    return f;
  }
  static V fma(const V& f, const T* x, V acc) {
    const T b = *x;
#pragma omp simd
    for (int r = 0; r < 16; ++r) acc.v[r] += f.v[r] * b;
    return acc;
  }
  static void store(T* y, const T* x, const T* rho, const T* e, const V& s, T a, T c, T d, size_t rows) {
    for (size_t r = 0; r < std::min<size_t>(rows, 16); ++r) y[r] = a * x[r] + c * rho[r] * s.v[r] + d * e[r];
  }
};
#endif

// What every block's product reads: the right-hand sides from q0 on (C / 3 of them), x transposed (xt).
template <class T>
struct BlockOperands {
  const Soa<T>* X;
  Soa<T>* Y;
  const Soa<T>* E;
  const Soa<T>* rho;
  const T* xt;
  size_t q0;
  T a, c, d;
};

// Block b for one group of C channels: its sums over its columns, then its rows of Y.
template <class Val, class T, int C>
[[gnu::noinline]] void row_block_product(const RowBlockMatrix& B, const BlockOperands<T>& o, size_t b) {
  using L = BlockLanes<Val, T>;
  using S = typename Val::stored;
  constexpr size_t kColBytes = kBlockRows * sizeof(S);
  const S* const first = static_cast<const S*>(B.data()) + size_t(B.col_start(b)) * kBlockRows;
  const BlockSegment* const seg = B.segments();
  const size_t i0 = b * kBlockRows;
  for (int part = 0; part < L::kParts; ++part) {
    // Every loop over acc is unrolled, so that the compiler keeps acc in registers (a loop over it left rolled, GCC 12
    // keeps it in memory too and stores all C vectors after every column: twice the time).
    typename L::V acc[C];
#pragma GCC unroll 24
    for (int ch = 0; ch < C; ++ch) acc[ch] = L::zero();
    const S* v = first;
    size_t p = 0;  // the block's columns so far: F's next line is asked for once
    for (int64_t s = B.seg_start(b); s < B.seg_start(b + 1); ++s) {
      const BlockSegment g = seg[s];  // a copy: the loop's bound in a register, not read again after each store
      const T* x = o.xt + size_t(g.col) * C;
      for (uint32_t t = 0; t < g.length; ++t, ++p, v += kBlockRows, x += C) {
        if (part == 0 && (p * kColBytes) % kCacheLine == 0)
          __builtin_prefetch(reinterpret_cast<const char*>(v) + kSparsePrefetchBytes);
        const typename L::V f = L::load(v, part);
#pragma GCC unroll 24
        for (int ch = 0; ch < C; ++ch) acc[ch] = L::fma(f, x + ch, acc[ch]);
      }
    }
    const size_t r0 = i0 + size_t(part) * L::kWidth;
    if (r0 >= B.n()) break;
    const size_t rows = B.n() - r0;
#pragma GCC unroll 24
    for (int ch = 0; ch < C; ++ch) {
      const size_t q = o.q0 + size_t(ch / 3);
      const int c3 = ch % 3;
      L::store(o.Y[q].data(c3) + r0, o.X[q].data(c3) + r0, o.rho->data(c3) + r0, o.E[q].data(c3) + r0, acc[ch], o.a,
               o.c, o.d, rows);
    }
  }
}

// row_block_product for the group's channel count (3 per right-hand side).
template <class Val, class T>
void row_block_group(const RowBlockMatrix& B, const BlockOperands<T>& o, size_t count, size_t b) {
  switch (count) {
    case 1: return row_block_product<Val, T, 3>(B, o, b);
    case 2: return row_block_product<Val, T, 6>(B, o, b);
    case 3: return row_block_product<Val, T, 9>(B, o, b);
    case 4: return row_block_product<Val, T, 12>(B, o, b);
    case 5: return row_block_product<Val, T, 15>(B, o, b);
    case 6: return row_block_product<Val, T, 18>(B, o, b);
    case 7: return row_block_product<Val, T, 21>(B, o, b);
    default: return row_block_product<Val, T, 24>(B, o, b);
  }
}

// The whole product (c: the float16 scale already in it): X transposed per group, then each thread its range of
// blocks, balanced by their columns (entry_block), every group of a block before the next block. Y must not alias X.
template <class Val, class Exec, class T>
void row_block_matvec(const Exec& ex, const RowBlockMatrix& B, const std::vector<Soa<T>>& X, std::vector<Soa<T>>& Y,
                      const Soa<T>& rho, const std::vector<Soa<T>>& E, T a, T c, T d) {
  const size_t n = B.n(), k = X.size(), ng = (k + kBlockGroup - 1) / kBlockGroup;
  if (n == 0 || k == 0) return;
  static thread_local std::vector<T> xt;
  xt.resize(ng * n * 3 * kBlockGroup);
  T* const xtp = xt.data();  // this thread's buffer: the name xt in the threads below would be theirs
  ex.rows(n, [&](size_t j0, size_t j1) {
    for (size_t g = 0; g < ng; ++g) {
      const size_t q0 = g * kBlockGroup, count = std::min(kBlockGroup, k - q0), C = 3 * count;
      T* col = xtp + g * n * 3 * kBlockGroup;
      for (size_t j = j0; j < j1; ++j)
        for (size_t q = 0; q < count; ++q)
          for (int ch = 0; ch < 3; ++ch) col[j * C + 3 * q + size_t(ch)] = X[q0 + q](j, ch);
    }
  });
  ex.each_thread([&](int t, int nt) {
    const auto [b0, b1] = entry_block(B.col_starts(), 0, B.blocks(), t, nt);
    for (size_t b = b0; b < b1; ++b)
      for (size_t g = 0; g < ng; ++g) {
        const size_t q0 = g * kBlockGroup, count = std::min(kBlockGroup, k - q0);
        const BlockOperands<T> o{X.data(), Y.data(), E.data(), &rho, xtp + g * n * 3 * kBlockGroup, q0, a, c, d};
        row_block_group<Val, T>(B, o, count, b);
      }
  });
}

}  // namespace radiosity
