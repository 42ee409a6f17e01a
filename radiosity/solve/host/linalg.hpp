// The linear algebra of the solvers (report §3.7: matrix-vector product, dot, axpby), written once over the
// layout accessor v(i, c) and the row-sharing façade of exec.hpp, so one source serves AOS, SOA and grey, serial
// and OpenMP, float and double, and every storage of F. Dots accumulate in double whatever T is: they decide
// convergence and cost O(n).
#pragma once
#include <algorithm>
#include <cmath>
#include <type_traits>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/host/csr_kernels.hpp"
#include "radiosity/solve/host/row_block_kernels.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/core/layout.hpp"
#include "radiosity/solve/storage/stored_values.hpp"

namespace radiosity {

// The dense product computes kGroup rows at a time (see matvec_rows).
inline constexpr size_t kGroup = 4;

// How far ahead of its loads sums4 asks for each row of F. The hardware prefetcher alone kept a Jacobi step on
// room3 (float32, 2 threads, this project's EPYC VM) at 13.4-17.4 ms; with 1 KiB to 4 KiB of software prefetch
// it ran at 11.0-13.3 ms in the same alternating runs (the four rows are four streams that restart every row; the
// prefetcher ramps up again on each). Asking again for a line on its way costs only an issue slot, and a prefetch
// past the end of F never faults.
inline constexpr size_t kPrefetchBytes = 2048;

// Four rows' partial sums over m columns: s[r][ch] += Σ_j F_r[j] x_ch[j], F_r stored as Val, x one contiguous array
// per channel.
template <class Val, int Channels, class T>
inline void sums4(const typename Val::stored* const (&F)[kGroup], const T* __restrict x0, const T* __restrict x1,
                  const T* __restrict x2, size_t m, T (&s)[kGroup][3]) {
#ifdef HPCGI_AVX2_SUMS
  if constexpr (Channels == 3 && std::is_same_v<T, float>) {
    // Every 8 columns load x's three channels and each row's F once: 7 loads for 12 fused multiply-adds, the twelve
    // sums in registers. GCC's vectorization of the generic loop below also keeps the sums in registers but loads
    // an operand again for every multiply-add (24 loads), and a 16-bit F costs it a shift-and-blend per value; the
    // loads then set the speed even where F comes from cache.
    __m256 acc[kGroup][3];
    for (size_t r = 0; r < kGroup; ++r)
      for (int ch = 0; ch < 3; ++ch) acc[r][ch] = _mm256_setzero_ps();
    size_t j = 0;
    for (; j + 8 <= m; j += 8) {
      const __m256 u0 = _mm256_loadu_ps(x0 + j), u1 = _mm256_loadu_ps(x1 + j), u2 = _mm256_loadu_ps(x2 + j);
      for (size_t r = 0; r < kGroup; ++r) {
        _mm_prefetch(reinterpret_cast<const char*>(F[r] + j) + kPrefetchBytes, _MM_HINT_T0);
        const __m256 f = Val::load8(F[r] + j);
        acc[r][0] = _mm256_fmadd_ps(f, u0, acc[r][0]);
        acc[r][1] = _mm256_fmadd_ps(f, u1, acc[r][1]);
        acc[r][2] = _mm256_fmadd_ps(f, u2, acc[r][2]);
      }
    }
    const T* const x[3] = {x0, x1, x2};
    for (size_t r = 0; r < kGroup; ++r)
      for (int ch = 0; ch < 3; ++ch) {
        // The eight lanes added pairwise, then the columns past the last multiple of 8.
        const __m128 h = _mm_add_ps(_mm256_castps256_ps128(acc[r][ch]), _mm256_extractf128_ps(acc[r][ch], 1));
        const __m128 q = _mm_add_ps(h, _mm_movehl_ps(h, h));
        float t = _mm_cvtss_f32(_mm_add_ss(q, _mm_shuffle_ps(q, q, 1)));
        for (size_t k = j; k < m; ++k) t += Val::get(F[r], k) * x[ch][k];
        s[r][ch] += t;
      }
    return;
  }
#endif
  const typename Val::stored *__restrict Fa = F[0], *__restrict Fb = F[1], *__restrict Fc = F[2],
                             *__restrict Fd = F[3];
  T a0 = s[0][0], a1 = s[0][1], a2 = s[0][2], b0 = s[1][0], b1 = s[1][1], b2 = s[1][2];
  T c0 = s[2][0], c1 = s[2][1], c2 = s[2][2], d0 = s[3][0], d1 = s[3][1], d2 = s[3][2];
  if constexpr (Channels == 3) {
    // The simd reduction lets the compiler keep partial sums per lane (it may not reorder a plain floating-point
    // sum); without it the loop stays scalar.
#pragma omp simd reduction(+ : a0, a1, a2, b0, b1, b2, c0, c1, c2, d0, d1, d2)
    for (size_t j = 0; j < m; ++j) {
      const T u0 = x0[j], u1 = x1[j], u2 = x2[j];
      const T fa = Val::get(Fa, j), fb = Val::get(Fb, j), fc = Val::get(Fc, j), fd = Val::get(Fd, j);
      a0 += fa * u0;
      a1 += fa * u1;
      a2 += fa * u2;
      b0 += fb * u0;
      b1 += fb * u1;
      b2 += fb * u2;
      c0 += fc * u0;
      c1 += fc * u1;
      c2 += fc * u2;
      d0 += fd * u0;
      d1 += fd * u1;
      d2 += fd * u2;
    }
  } else {
#pragma omp simd reduction(+ : a0, b0, c0, d0)
    for (size_t j = 0; j < m; ++j) {
      const T u0 = x0[j];
      a0 += T(Val::get(Fa, j)) * u0;
      b0 += T(Val::get(Fb, j)) * u0;
      c0 += T(Val::get(Fc, j)) * u0;
      d0 += T(Val::get(Fd, j)) * u0;
    }
  }
  s[0][0] = a0, s[0][1] = a1, s[0][2] = a2, s[1][0] = b0, s[1][1] = b1, s[1][2] = b2;
  s[2][0] = c0, s[2][1] = c1, s[2][2] = c2, s[3][0] = d0, s[3][1] = d1, s[3][2] = d2;
}

// Rows of y = a·x + c·ρ ⊙ (F x) + d·e for a dense F, all channels in one pass over F: each F_ij is read once and
// feeds every channel's accumulator. This pass moves n² values against O(n) for everything else, so it sets the
// speed of the solver. The rows are row(k), k in [k0, k1), with row(k) = k, or rows[k] when only some rows are
// computed (the others belong to patches with reflectivity 0; see affine_matvec). Four rows at a time: four
// streams of F per thread keep more misses in flight than one or two (a read sweep on this project's 2-core EPYC
// VM runs about 1.8 times as fast with four streams per core as with one), and each x_j, once loaded, serves four
// F values. A row's sums do not depend on which rows share its group, so the bits are the same whatever the
// thread count and however a thread's rows are grouped (see below). Kept out of line so that every backend and
// thread count runs the same machine code for a row (inlined, the compiler may vectorize each caller's copy
// differently and move the last bits).
// F holds the rows from first_row on (0: the whole matrix; an MPI rank's block of rows: its first row), row i at
// F + (i - first_row)·n.
template <class Val, class V>
[[gnu::noinline]] void matvec_rows(const typename Val::stored* F, const int32_t* rows, const V& x, V& y,
                                   const V& rho, const V& e, typename V::value_type a, typename V::value_type c,
                                   typename V::value_type d, size_t k0, size_t k1, size_t first_row = 0) {
  using T = typename V::value_type;
  constexpr int C = V::kChannels;
  const size_t n = x.size();
  // The inner loop reads x one array per channel: AOS records are de-interleaved once per call into this thread's
  // scratch (3n values, in L2 for room3), not once per group of rows in the loop, where the shuffles cost as much
  // as the multiplies. So AOS and SOA run the same loop and give the same bits.
  const T *x0 = x.data(0), *x1 = x.data(1), *x2 = x.data(2);
  if constexpr (V::kStep != 1) {
    static thread_local std::optional<Soa<T>> soa;  // each channel on a cache line, as in the SOA layout
    if (!soa || soa->size() != n) soa.emplace(n);
    for (size_t j = 0; j < n; ++j)
      for (int ch = 0; ch < 3; ++ch) (*soa)(j, ch) = x(j, ch);
    x0 = soa->data(0), x1 = soa->data(1), x2 = soa->data(2);
  }
  auto row = [&](size_t k) { return rows ? size_t(rows[k]) : k; };
  auto store = [&](size_t i, const T (&s)[3]) {
    y(i, 0) = a * x(i, 0) + c * rho(i, 0) * s[0] + d * e(i, 0);
    if constexpr (C == 3) {
      y(i, 1) = a * x(i, 1) + c * rho(i, 1) * s[1] + d * e(i, 1);
      y(i, 2) = a * x(i, 2) + c * rho(i, 2) * s[2] + d * e(i, 2);
    }
  };
  // The four rows of a group come from the four quarters of [k0, k1): group g sums rows k0 + g, k0 + q + g,
  // k0 + 2q + g and k0 + 3q + g (q = quarter). So each of the four streams of F runs on from one row into the next,
  // one long sequential sweep per quarter as in bin/stream's read sweep, instead of four streams that end every
  // row. A row's sums do not depend on the rows beside it, so the grouping leaves the bits alone. A quarter that
  // runs out repeats its group's first row in its place, so every row is summed by the same code (and a 16-bit row
  // gives the bits of its float32 widening).
  const size_t quarter = (k1 - k0 + kGroup - 1) / kGroup;
  for (size_t g = 0; g < quarter; ++g) {
    size_t i[kGroup], rows_here = 1;
    i[0] = row(k0 + g);
    for (size_t r = 1; r < kGroup; ++r) {
      const size_t k = k0 + r * quarter + g;
      i[r] = k < k1 ? row(k) : i[0];
      rows_here += k < k1;
    }
    T s[kGroup][3] = {};
    const typename Val::stored* const Fr[kGroup] = {F + (i[0] - first_row) * n, F + (i[1] - first_row) * n,
                                                    F + (i[2] - first_row) * n, F + (i[3] - first_row) * n};
    sums4<Val, C>(Fr, x0, x1, x2, n, s);
    for (size_t r = 0; r < rows_here; ++r) store(i[r], s[r]);
  }
}

// y = a·x + d·e on rows whose reflectivity is 0 in every channel: their ρ ⊙ (F x) is 0 whatever F x is.
template <class V>
void matvec_skipped_row(const V& x, V& y, const V& e, typename V::value_type a, typename V::value_type d, size_t i) {
  for (int ch = 0; ch < V::kChannels; ++ch) y(i, ch) = a * x(i, ch) + d * e(i, ch);
}

// y = a·x + c·ρ ⊙ (F x) + d·e for a dense F of stored values Val, on rows [row_begin, row_end) (default: all; an
// MPI rank's block, F then holding only those rows from its first: see matvec_rows). `rows`: the rows to compute,
// increasing (the others are patches with reflectivity 0, given a·x + d·e), or empty for all. Each thread computes
// the rows of its block (matvec_rows gives a row the same bits whatever rows it is grouped with). y must not be x.
template <class Val, class Exec, class V>
void dense_matvec(const Exec& ex, const typename Val::stored* F, const std::vector<int32_t>& rows, const V& x, V& y,
                  const V& rho, const V& e, typename V::value_type a, typename V::value_type c,
                  typename V::value_type d, size_t row_begin = 0, size_t row_end = SIZE_MAX) {
  const size_t b0 = row_begin, b1 = std::min(row_end, x.size());
  if (b1 <= b0) return;
  if (rows.empty()) {
    ex.rows(b1 - b0, [&](size_t t0, size_t t1) {
      matvec_rows<Val>(F, nullptr, x, y, rho, e, a, c, d, b0 + t0, b0 + t1, b0);
    });
    return;
  }
  const auto index_of = [&rows](size_t i) {  // the first k with rows[k] >= i
    return size_t(std::lower_bound(rows.begin(), rows.end(), int64_t(i)) - rows.begin());
  };
  ex.rows(b1 - b0, [&](size_t t0, size_t t1) {
    const size_t i0 = b0 + t0, i1 = b0 + t1;
    const size_t lo = index_of(i0), hi = index_of(i1);
    for (size_t i = i0, k = lo; i < i1; ++i) {
      if (k < hi && size_t(rows[k]) == i)
        ++k;
      else
        matvec_skipped_row(x, y, e, a, d, i);
    }
    if (lo < hi) matvec_rows<Val>(F, rows.data(), x, y, rho, e, a, c, d, lo, hi, b0);
  });
}

// The product for any stored matrix (ff_matrix.hpp): dispatched once per pass to the kernel of its storage and
// values (dense here, csr, compressed and runs in csr_kernels.hpp). The float16 scale is folded into c (a power of
// two: exact). Rows [row_begin, row_end) only: an MPI rank's block (a dense F then holds those rows, from row_begin
// on; a sparse one indexes every row).
template <class Exec, class V>
void affine_matvec(const Exec& ex, const FFMatrixView& F, const std::vector<int32_t>& rows, const V& x, V& y,
                   const V& rho, const V& e, typename V::value_type a, typename V::value_type c,
                   typename V::value_type d, size_t row_begin = 0, size_t row_end = SIZE_MAX) {
  using T = typename V::value_type;
  const T cs = T(double(c) * F.scale);
  auto run = [&](auto values) {
    using Val = decltype(values);
    const auto* data = static_cast<const typename Val::stored*>(F.data);
    if (F.storage == FFStorage::dense)
      dense_matvec<Val>(ex, data, rows, x, y, rho, e, a, cs, d, row_begin, row_end);
    else
      sparse_matvec<Val>(ex, F, x, y, rho, e, a, cs, d, row_begin, row_end);
  };
  switch (F.values) {
    case FFValues::float32: run(Float32Values{}); break;
    case FFValues::float16: run(Float16Values{}); break;
    case FFValues::bfloat16: run(BFloat16Values{}); break;
  }
}

// The product with k right-hand sides (relighting: one per light, radiosity/relight/): Y_q = a·X_q + c·ρ ⊙ (F X_q)
// + d·E_q for q < k, each X_q three channels (SOA), from F's row blocks (row_blocks.hpp; built once from F in any
// storage, its rows of reflectivity 0 empty), all right-hand sides in one pass over them (row_block_kernels.hpp).
// X, Y and E hold k vectors each; Y must not alias X. The float16 scale is folded into c. For k = 1 the solvers'
// product (affine_matvec on Soa vectors) reads F's own storage and fewer bytes.
template <class Exec, class T>
void multi_affine_matvec(const Exec& ex, const RowBlockMatrix& F, const std::vector<Soa<T>>& X,
                         std::vector<Soa<T>>& Y, const Soa<T>& rho, const std::vector<Soa<T>>& E, T a, T c, T d) {
  if (Y.size() != X.size() || E.size() != X.size())
    throw std::invalid_argument("multi_affine_matvec: X, Y and E differ in count");
  const T cs = T(double(c) * F.scale());
  switch (F.values()) {
    case FFValues::float32: return row_block_matvec<Float32Values>(ex, F, X, Y, rho, E, a, cs, d);
    case FFValues::float16: return row_block_matvec<Float16Values>(ex, F, X, Y, rho, E, a, cs, d);
    case FFValues::bfloat16: return row_block_matvec<BFloat16Values>(ex, F, X, Y, rho, E, a, cs, d);
  }
}

// y = a·x + c·ρ ⊙ (F x) + d·e for dense float32 F, every row. With (a, c, d) = (0, 1, 1) it is a Jacobi step,
// (1, -1, 0) the product A x, (-1, 1, 1) the residual e - A x. y must not be x.
template <class Exec, class V>
void affine_matvec(const Exec& ex, const float* F, const V& x, V& y, const V& rho, const V& e,
                   typename V::value_type a, typename V::value_type c, typename V::value_type d) {
  dense_matvec<Float32Values>(ex, F, {}, x, y, rho, e, a, c, d);
}

// Σ_i x_ic y_ic per channel (one channel: the same sum for r, g and b).
template <class Exec, class V>
Rgb dot(const Exec& ex, const V& x, const V& y) {
  if constexpr (V::kChannels == 1)
    return ex.reduce(x.size(), [&](size_t i0, size_t i1) {
      double s = 0;
#pragma omp simd reduction(+ : s)
      for (size_t i = i0; i < i1; ++i) s += double(x(i, 0)) * y(i, 0);
      return Rgb{s, s, s};
    });
  return ex.reduce(x.size(), [&](size_t i0, size_t i1) {
    double s0 = 0, s1 = 0, s2 = 0;
#pragma omp simd reduction(+ : s0, s1, s2)
    for (size_t i = i0; i < i1; ++i) {
      s0 += double(x(i, 0)) * y(i, 0);
      s1 += double(x(i, 1)) * y(i, 1);
      s2 += double(x(i, 2)) * y(i, 2);
    }
    return Rgb{s0, s1, s2};
  });
}

// Σ_i (x_ic - y_ic)² per channel: for Jacobi, the squared residual of the previous iterate (see jacobi.cpp).
template <class Exec, class V>
Rgb dist2(const Exec& ex, const V& x, const V& y) {
  if constexpr (V::kChannels == 1)
    return ex.reduce(x.size(), [&](size_t i0, size_t i1) {
      double s = 0;
#pragma omp simd reduction(+ : s)
      for (size_t i = i0; i < i1; ++i) {
        const double d0 = double(x(i, 0)) - y(i, 0);
        s += d0 * d0;
      }
      return Rgb{s, s, s};
    });
  return ex.reduce(x.size(), [&](size_t i0, size_t i1) {
    double s0 = 0, s1 = 0, s2 = 0;
#pragma omp simd reduction(+ : s0, s1, s2)
    for (size_t i = i0; i < i1; ++i) {
      const double d0 = double(x(i, 0)) - y(i, 0), d1 = double(x(i, 1)) - y(i, 1), d2 = double(x(i, 2)) - y(i, 2);
      s0 += d0 * d0;
      s1 += d1 * d1;
      s2 += d2 * d2;
    }
    return Rgb{s0, s1, s2};
  });
}

// max_i |x_ic - y_ic| per channel (y = nullptr: max_i |x_ic|), for the ∞-norm stopping rules.
template <class Exec, class V>
Rgb max_abs_diff(const Exec& ex, const V& x, const V* y) {
  return ex.reduce_max(x.size(), [&](size_t i0, size_t i1) {
    Rgb m{0, 0, 0};
    for (size_t i = i0; i < i1; ++i)
      for (int c = 0; c < V::kChannels; ++c) {
        const double d = std::abs(double(x(i, c)) - (y ? double((*y)(i, c)) : 0.0));
        if (std::isnan(d) || d > m[c]) m[c] = d;
      }
    if constexpr (V::kChannels == 1) m[1] = m[2] = m[0];
    return m;
  });
}

// y = a ⊙ x + b ⊙ y with one coefficient per channel (one channel: a[0], b[0]; the methods give the three
// channels of a grey system equal coefficients, as their dots are equal).
template <class Exec, class V>
void axpby(const Exec& ex, V& y, const Rgb& a, const V& x, const Rgb& b) {
  using T = typename V::value_type;
  const T a0 = T(a[0]), a1 = T(a[1]), a2 = T(a[2]), b0 = T(b[0]), b1 = T(b[1]), b2 = T(b[2]);
  if constexpr (V::kChannels == 1) {
    ex.rows(x.size(), [&](size_t i0, size_t i1) {
#pragma omp simd
      for (size_t i = i0; i < i1; ++i) y(i, 0) = a0 * x(i, 0) + b0 * y(i, 0);
    });
    return;
  }
  ex.rows(x.size(), [&](size_t i0, size_t i1) {
#pragma omp simd
    for (size_t i = i0; i < i1; ++i) {
      y(i, 0) = a0 * x(i, 0) + b0 * y(i, 0);
      y(i, 1) = a1 * x(i, 1) + b1 * y(i, 1);
      y(i, 2) = a2 * x(i, 2) + b2 * y(i, 2);
    }
  });
}

template <class Exec, class V>
void copy(const Exec& ex, V& y, const V& x) {
  ex.rows(x.size(), [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i)
      for (int c = 0; c < V::kChannels; ++c) y(i, c) = x(i, c);
  });
}

// Host values in and out of a vector, and fresh zero vectors, each row written by the thread whose rows it are (for
// a new vector: its first touch), as every kernel above shares them out.
template <class Exec, class V>
void load(const Exec& ex, V& dst, const std::vector<Rgb>& src) {
  using T = typename V::value_type;
  ex.rows(dst.size(), [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i)
      for (int c = 0; c < V::kChannels; ++c) dst(i, c) = T(src[i][c]);
  });
}

template <class Exec, class V>
void store(const Exec& ex, const V& src, std::vector<Rgb>& dst) {  // a single channel fills r, g and b alike
  dst.resize(src.size());
  ex.rows(src.size(), [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i)
      for (int c = 0; c < 3; ++c) dst[i][c] = src(i, c);
  });
}

template <class V, class Exec>
std::vector<V> zero_vectors(const Exec& ex, size_t n, int count) {
  std::vector<V> out;
  out.reserve(size_t(count));
  for (int k = 0; k < count; ++k) {
    V& v = out.emplace_back(n);
    ex.rows(n, [&](size_t i0, size_t i1) {
      for (size_t i = i0; i < i1; ++i)
        for (int c = 0; c < V::kChannels; ++c) v(i, c) = 0;
    });
  }
  return out;
}

}  // namespace radiosity
