// The linear algebra of the solvers (report §3.7: matrix-vector product, dot, axpby), written once over the
// layout accessor v(i, c) and the row-sharing façade of exec.hpp, so one source serves AOS and SOA, serial and
// OpenMP, float and double. Dots accumulate in double whatever T is: they decide convergence and cost O(n).
#pragma once
#include <cstddef>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/layout.hpp"

namespace radiosity {

// Rows [i0, i1) of y = a·x + c·ρ ⊙ (F x) + d·e, all three channels in one pass over F: each F_ij is read once
// and feeds three accumulators. This pass moves 4n² bytes against O(n) for everything else, so it sets the speed
// of the solver. Four rows at a time: four streams of F per thread keep more misses in flight than one or two (a
// read sweep on this project's 2-core EPYC VM runs about 1.8 times as fast with four streams per core as with
// one), and each x_j, once loaded (and for AOS de-interleaved, the costly part), serves four F values. i0 is a
// multiple of 4 (blocks start on kRowAlign), so a row is grouped alike whatever the thread count.
// Kept out of line so that every backend and thread count runs the same machine code for a row (inlined, the
// compiler may vectorize each caller's copy differently and move the last bits).
template <class V>
[[gnu::noinline]] void matvec_rows(const float* F, const V& x, V& y, const V& rho, const V& e,
                                   typename V::value_type a, typename V::value_type c, typename V::value_type d,
                                   size_t i0, size_t i1) {
  using T = typename V::value_type;
  constexpr size_t S = V::kStep;
  static_assert(kRowAlign % 4 == 0, "row blocks must start on a group of four rows");
  const size_t n = x.size();
  const T* __restrict x0 = x.data(0);
  const T* __restrict x1 = x.data(1);
  const T* __restrict x2 = x.data(2);
  auto store = [&](size_t i, T s0, T s1, T s2) {
    y(i, 0) = a * x(i, 0) + c * rho(i, 0) * s0 + d * e(i, 0);
    y(i, 1) = a * x(i, 1) + c * rho(i, 1) * s1 + d * e(i, 1);
    y(i, 2) = a * x(i, 2) + c * rho(i, 2) * s2 + d * e(i, 2);
  };
  size_t i = i0;
  for (; i + 3 < i1; i += 4) {
    const float* __restrict Fa = F + i * n;
    const float* __restrict Fb = Fa + n;
    const float* __restrict Fc = Fb + n;
    const float* __restrict Fd = Fc + n;
    T a0 = 0, a1 = 0, a2 = 0, b0 = 0, b1 = 0, b2 = 0, c0 = 0, c1 = 0, c2 = 0, d0 = 0, d1 = 0, d2 = 0;
    // The simd reduction lets the compiler keep partial sums per lane (it may not reorder a plain floating-point
    // sum); without it the loop stays scalar.
#pragma omp simd reduction(+ : a0, a1, a2, b0, b1, b2, c0, c1, c2, d0, d1, d2)
    for (size_t j = 0; j < n; ++j) {
      const T u0 = x0[j * S], u1 = x1[j * S], u2 = x2[j * S];
      const T fa = Fa[j], fb = Fb[j], fc = Fc[j], fd = Fd[j];
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
    store(i, a0, a1, a2);
    store(i + 1, b0, b1, b2);
    store(i + 2, c0, c1, c2);
    store(i + 3, d0, d1, d2);
  }
  for (; i < i1; ++i) {  // the last rows when n is not a multiple of 4
    const float* __restrict Fa = F + i * n;
    T a0 = 0, a1 = 0, a2 = 0;
#pragma omp simd reduction(+ : a0, a1, a2)
    for (size_t j = 0; j < n; ++j) {
      const T fa = Fa[j];
      a0 += fa * x0[j * S];
      a1 += fa * x1[j * S];
      a2 += fa * x2[j * S];
    }
    store(i, a0, a1, a2);
  }
}

// y = a·x + c·ρ ⊙ (F x) + d·e. With (a, c, d) = (0, 1, 1) it is a Jacobi step, (1, -1, 0) the product A x,
// (-1, 1, 1) the residual e - A x. y must not be x. F stays float32 whatever T is.
template <class Exec, class V>
void affine_matvec(const Exec& ex, const float* F, const V& x, V& y, const V& rho, const V& e,
                   typename V::value_type a, typename V::value_type c, typename V::value_type d) {
  ex.rows(x.size(), [&](size_t i0, size_t i1) { matvec_rows(F, x, y, rho, e, a, c, d, i0, i1); });
}

// Σ_i x_ic y_ic per channel.
template <class Exec, class V>
Rgb dot(const Exec& ex, const V& x, const V& y) {
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

// y = a ⊙ x + b ⊙ y with one coefficient per channel.
template <class Exec, class V>
void axpby(const Exec& ex, V& y, const Rgb& a, const V& x, const Rgb& b) {
  using T = typename V::value_type;
  const T a0 = T(a[0]), a1 = T(a[1]), a2 = T(a[2]), b0 = T(b[0]), b1 = T(b[1]), b2 = T(b[2]);
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
      for (int c = 0; c < 3; ++c) y(i, c) = x(i, c);
  });
}

}  // namespace radiosity
