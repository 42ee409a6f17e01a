// The product y = a·x + c·ρ ⊙ (F x) + d·e for F in runs storage (ff_matrix.hpp): each row a list of runs of
// consecutive columns, all channels in one pass over the values, rows shared out between threads by their entries
// (csr_kernels.hpp's sparse_matvec calls it, with entry_block), for every value type (float32, float16, bfloat16).
//
// A run is a dense dot product: its values contiguous, x_j..x_{j+L-1} contiguous in each channel, so no gathers.
// x is read as one array per channel (SOA as it is; AOS de-interleaved once per product into this thread's scratch,
// 3n values: room3's 9680 patches in 116 KB, L2). A run's length varies, so a loop over it that ends on its length
// mispredicts once a run (room3: 42% of runs hold at most 8 values, 20% more than 32). Hence the storage caps a run
// at kRunMaxLength = 16 values (ff_matrix.hpp), and:
//   AVX-512 (-march=native here): a run in ONE block of 16 under a mask (_bzhi of its length), F loaded masked (F16C
//     widening in vcvtph2ps), x by masked loads: no branch on the length, no lane past the run read (a longer run,
//     from a file written before the cap, takes full blocks first);
//   AVX2 (the GPU kit's x86-64-v3): blocks of 8 while more than 32 values are left, then the last 1-32 in four
//     blocks of 8 under masks from a table (F loaded whole and masked, its buffer kRunValuePad values longer; x by
//     masked loads), again no branch on a run's length up to 32;
//   otherwise a plain loop the compiler vectorizes.
// Consecutive runs alternate between two sets of three accumulators, and each run's values are prefetched
// kRunPrefetchBytes ahead. Capped runs and one block a run took room3's float16 product (2 threads) from 2.4 to
// 1.8 ms. A row's sum depends on its runs only, not on the layout, the thread count or the rows beside it: AOS and
// SOA, serial and openmp with any threads give the same bits (for one build: the three paths sum in different
// orders).
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <type_traits>

#include "radiosity/solve/core/layout.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/storage/stored_values.hpp"

namespace radiosity {

// x as the runs kernel reads it: one contiguous array per channel (SOA and grey as they are; AOS copied into this
// thread's scratch once per product).
template <class V>
void channel_arrays(const V& x, const typename V::value_type* (&xc)[3]) {
  using T = typename V::value_type;
  for (int ch = 0; ch < 3; ++ch) xc[ch] = x.data(V::kChannels == 3 ? ch : 0);
  if constexpr (V::kStep != 1) {
    static thread_local std::optional<Soa<T>> soa;
    const size_t n = x.size();
    if (!soa || soa->size() != n) soa.emplace(n);
    for (size_t j = 0; j < n; ++j)
      for (int ch = 0; ch < 3; ++ch) (*soa)(j, ch) = x(j, ch);
    for (int ch = 0; ch < 3; ++ch) xc[ch] = soa->data(ch);
  }
}

// How far ahead of a run its values are asked for (see kPrefetchBytes, linalg.hpp): on room3, 1 thread, the AVX2
// product took 9.3 ms without and 7.3 ms with 1 KiB (a loaded machine, minimum of 30); the AVX-512 product of capped
// runs (float16, 2 threads, medians of 20) 2.0 ms at 1 KiB, 1.8-2.1 at 2 KiB, 1.69-1.75 at 4 KiB, 1.87-2.06 at 8.
inline constexpr size_t kRunPrefetchBytes = 4096;

#ifdef HPCGI_AVX2_SUMS
// A run's values, kRunPrefetchBytes ahead: one line a run (a run of 16 values is at most 64 bytes).
inline void prefetch_run(const void* f) {
  _mm_prefetch(static_cast<const char*>(f) + kRunPrefetchBytes, _MM_HINT_T0);
}
#endif

#ifdef HPCGI_AVX2_SUMS
// kTailMasks[r]: 32 lanes (four blocks of 8), the first r set (r in 0..32).
struct TailMasks {
  alignas(64) int32_t m[33][32];
  constexpr TailMasks() : m() {
    for (int r = 0; r <= 32; ++r)
      for (int l = 0; l < 32; ++l) m[r][l] = l < r ? -1 : 0;
  }
  const int32_t* operator[](size_t r) const { return m[r]; }
};
inline constexpr TailMasks kTailMasks{};
#endif

// A row's sums over its runs, one run at a time (add: the run's values f, x from p0, p1, p2 on; total: the sums).
// The plain one: a loop the compiler vectorizes, for every T and channel count.
template <class Val, class T, int C>
struct PlainRunSums {
  T s[3] = {0, 0, 0};
  template <int B>  // (one set of sums: B is the SIMD sums' alternation)
  void add(const typename Val::stored* f, const T* p0, const T* p1, const T* p2, size_t len) {
    T t0 = 0, t1 = 0, t2 = 0;
    if constexpr (C == 3) {
#pragma omp simd reduction(+ : t0, t1, t2)
      for (size_t q = 0; q < len; ++q) {
        const T fq = T(Val::get(f, q));
        t0 += fq * p0[q];
        t1 += fq * p1[q];
        t2 += fq * p2[q];
      }
    } else {
#pragma omp simd reduction(+ : t0)
      for (size_t q = 0; q < len; ++q) t0 += T(Val::get(f, q)) * p0[q];
    }
    s[0] += t0, s[1] += t1, s[2] += t2;
  }
  void total(T (&out)[3]) const { out[0] = s[0], out[1] = s[1], out[2] = s[2]; }
};

#ifdef HPCGI_AVX512_SUMS
// AVX-512: a run of up to 16 values (every run the storage builds: kRunMaxLength) in ONE block under a mask (_bzhi:
// the run's lanes), so there is no branch on a run's length, and no lane past the run is loaded or added; a longer
// run (a file written with longer runs) takes full blocks first. Runs alternate between two sets of three
// accumulators (B), so that consecutive runs' multiply-adds do not wait for each other. Tried for issue 37 and not
// kept (room3 float16, loaded machine, development only): four sets taken in turn, no faster; runs capped at 8 values
// in one 256-bit block each (a Zen 4 core splits a 512-bit operation in two halves), 8% slower, the more runs costing
// more than the narrower blocks saved.
template <class Val, int C>
struct Avx512RunSums {
  // One block of up to 16 values under mask m into the accumulators s0..s2.
  static void block(const typename Val::stored* f, const float* p0, const float* p1, const float* p2, __mmask16 m,
                    __m512& s0, __m512& s1, __m512& s2) {
    const __m512 fa = Val::load16(f, m);
    s0 = _mm512_fmadd_ps(fa, _mm512_maskz_loadu_ps(m, p0), s0);
    if constexpr (C == 3) {
      s1 = _mm512_fmadd_ps(fa, _mm512_maskz_loadu_ps(m, p1), s1);
      s2 = _mm512_fmadd_ps(fa, _mm512_maskz_loadu_ps(m, p2), s2);
    }
  }
  // A whole row, its runs [u, end), the accumulators local, in the same order of operations as a run at a time (the
  // same bits). Taken a run at a time through a member array, as the other sums are, GCC 12 kept the accumulators in
  // memory, stored them after every multiply-add and reloaded x's channel pointers: about 30 instructions a run,
  // where this loop has 19. On an Ice Lake Xeon VM (issue 37, room3, alternating runs, medians of 5, neighbours
  // busy) float16 went from 6.97 to 5.84 ms a step on 1 thread and 4.72 to 3.63 on 2; float32 9.22 to 8.57 and 5.76
  // to 5.12.
  static void row(const typename Val::stored* f, const FFRun* u, const FFRun* end, const float* const (&xc)[3],
                  float (&out)[3]) {
    const float *const x0 = xc[0], *const x1 = xc[1], *const x2 = xc[2];
    __m512 a0 = _mm512_setzero_ps(), a1 = a0, a2 = a0, b0 = a0, b1 = a0, b2 = a0;
    size_t j = 0;
    auto run = [&](const FFRun r, __m512& s0, __m512& s1, __m512& s2) {
      j += r.step;
      prefetch_run(f);
      size_t len = r.length;
      while (len > 16) {  // only a file written before the cap has such runs
        block(f, x0 + j, x1 + j, x2 + j, __mmask16(0xffff), s0, s1, s2);
        f += 16, j += 16, len -= 16;
      }
      block(f, x0 + j, x1 + j, x2 + j, __mmask16(_bzhi_u32(0xffff, uint32_t(len))), s0, s1, s2);
      f += len, j += len;
    };
    for (; u + 2 <= end; u += 2) {
      run(u[0], a0, a1, a2);
      run(u[1], b0, b1, b2);
    }
    if (u < end) run(u[0], a0, a1, a2);
    out[0] = lanes(_mm512_add_ps(a0, b0));
    out[1] = lanes(_mm512_add_ps(a1, b1));
    out[2] = lanes(_mm512_add_ps(a2, b2));
  }
  // The 16 lanes added pairwise in a fixed order (GCC 12's _mm512_reduce_add_ps warns: -Wmaybe-uninitialized).
  static float lanes(__m512 v) {
    alignas(64) float t[16];
    _mm512_store_ps(t, v);
    for (int w = 8; w > 0; w /= 2)
      for (int l = 0; l < w; ++l) t[l] += t[l + w];
    return t[0];
  }
};
#endif

#ifdef HPCGI_AVX2_SUMS
// AVX2: blocks of 8 while more than 32 values are left, then the last 1-32 in four blocks of 8 under masks
// (kTailMasks[left]: F loaded whole and masked, x by masked loads), again no branch on a run's length up to 32.
template <class Val, int C>
struct Avx2RunSums {
  __m256 a0 = _mm256_setzero_ps(), a1 = a0, a2 = a0, b0 = a0, b1 = a0, b2 = a0;
  // Two blocks of 8 at q, each under its mask (full blocks: all lanes).
  void pair(const typename Val::stored* f, const float* p0, const float* p1, const float* p2, __m256i ma,
            __m256i mb) {
    const __m256 fa = _mm256_and_ps(Val::load8(f), _mm256_castsi256_ps(ma));
    const __m256 fb = _mm256_and_ps(Val::load8(f + 8), _mm256_castsi256_ps(mb));
    a0 = _mm256_fmadd_ps(fa, _mm256_maskload_ps(p0, ma), a0);
    b0 = _mm256_fmadd_ps(fb, _mm256_maskload_ps(p0 + 8, mb), b0);
    if constexpr (C == 3) {
      a1 = _mm256_fmadd_ps(fa, _mm256_maskload_ps(p1, ma), a1);
      b1 = _mm256_fmadd_ps(fb, _mm256_maskload_ps(p1 + 8, mb), b1);
      a2 = _mm256_fmadd_ps(fa, _mm256_maskload_ps(p2, ma), a2);
      b2 = _mm256_fmadd_ps(fb, _mm256_maskload_ps(p2 + 8, mb), b2);
    }
  }
  template <int B>  // (the blocks alternate inside a run: B is the AVX-512 sums' alternation)
  void add(const typename Val::stored* f, const float* p0, const float* p1, const float* p2, size_t len) {
    prefetch_run(f);
    const __m256i all = _mm256_set1_epi32(-1);
    size_t q = 0;
    for (; q + 32 < len; q += 16) {
      _mm_prefetch(reinterpret_cast<const char*>(f + q) + kRunPrefetchBytes + 2 * kCacheLine, _MM_HINT_T0);
      pair(f + q, p0 + q, p1 + q, p2 + q, all, all);
    }
    const int32_t* mask = kTailMasks[len - q];
    for (size_t t = 0; t < 32; t += 16)
      pair(f + q + t, p0 + q + t, p1 + q + t, p2 + q + t,
           _mm256_load_si256(reinterpret_cast<const __m256i*>(mask + t)),
           _mm256_load_si256(reinterpret_cast<const __m256i*>(mask + t + 8)));
  }
  void total(float (&out)[3]) const {
    const __m256 acc[3] = {_mm256_add_ps(a0, b0), _mm256_add_ps(a1, b1), _mm256_add_ps(a2, b2)};
    for (int ch = 0; ch < 3; ++ch) {
      const __m128 h = _mm_add_ps(_mm256_castps256_ps128(acc[ch]), _mm256_extractf128_ps(acc[ch], 1));
      const __m128 q = _mm_add_ps(h, _mm_movehl_ps(h, h));
      out[ch] = _mm_cvtss_f32(_mm_add_ss(q, _mm_shuffle_ps(q, q, 1)));
    }
  }
};
#endif

#if defined(HPCGI_AVX512_SUMS)
template <class Val, class T, int C>
using RunSums = std::conditional_t<std::is_same_v<T, float>, Avx512RunSums<Val, C>, PlainRunSums<Val, T, C>>;
#elif defined(HPCGI_AVX2_SUMS)
template <class Val, class T, int C>
using RunSums = std::conditional_t<std::is_same_v<T, float>, Avx2RunSums<Val, C>, PlainRunSums<Val, T, C>>;
#else
template <class Val, class T, int C>
using RunSums = PlainRunSums<Val, T, C>;
#endif

// A row's sums over its runs [u, end), x from xc: Sums with a static row(f, u, end, xc, out) take the whole row at
// once (AVX-512), the others a run at a time, consecutive runs alternating between their two sets of sums (B).
template <class S, class = void>
inline constexpr bool kWholeRowSums = false;
template <class S>
inline constexpr bool kWholeRowSums<S, std::void_t<decltype(&S::row)>> = true;

template <class Sums, class Val, class T>
void row_sums(const typename Val::stored* f, const FFRun* u, const FFRun* end, const T* const (&xc)[3], T (&s)[3]) {
  if constexpr (kWholeRowSums<Sums>) {
    Sums::row(f, u, end, xc, s);
  } else {
    Sums acc;
    size_t j = 0;
    auto add = [&](auto b, const FFRun& r) {
      j += r.step;
      acc.template add<decltype(b)::value>(f, xc[0] + j, xc[1] + j, xc[2] + j, r.length);
      f += r.length;
      j += r.length;
    };
    for (; u + 2 <= end; u += 2) {
      add(std::integral_constant<int, 0>{}, u[0]);
      add(std::integral_constant<int, 1>{}, u[1]);
    }
    if (u < end) add(std::integral_constant<int, 0>{}, u[0]);
    acc.total(s);
  }
}

// Rows [i0, i1) of the product, F's values as Val (stored_values.hpp), x as one array per channel (xc), each row's
// sums by Sums (the build's best; the tests name the others). Out of line, so that every caller runs the same machine
// code for a row.
template <class Val, class V, class Sums = RunSums<Val, typename V::value_type, V::kChannels>>
[[gnu::noinline]] void runs_rows(const typename Val::stored* F, const FFRun* run, const int64_t* start,
                                 const int64_t* run_start, const typename V::value_type* const (&xc)[3], const V& x,
                                 V& y, const V& rho, const V& e, typename V::value_type a, typename V::value_type c,
                                 typename V::value_type d, size_t i0, size_t i1) {
  using T = typename V::value_type;
  constexpr int C = V::kChannels;
  for (size_t i = i0; i < i1; ++i) {
    T s[3];
    row_sums<Sums, Val>(F + size_t(start[i]), run + size_t(run_start[i]), run + size_t(run_start[i + 1]), xc, s);
    y(i, 0) = a * x(i, 0) + c * rho(i, 0) * s[0] + d * e(i, 0);
    if constexpr (C == 3) {
      y(i, 1) = a * x(i, 1) + c * rho(i, 1) * s[1] + d * e(i, 1);
      y(i, 2) = a * x(i, 2) + c * rho(i, 2) * s[2] + d * e(i, 2);
    }
  }
}

}  // namespace radiosity
