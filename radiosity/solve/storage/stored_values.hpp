// How the kernels read a stored form factor (ff_matrix.hpp): as float, whatever it is stored as. get reads one
// value; load8 (AVX2) eight consecutive ones into a vector of floats: F16C's vcvtph2ps widens eight halves in one
// instruction, a bfloat16 is widened by a zero-extension and a shift. Shared by the dense (linalg.hpp) and the
// sparse (csr_kernels.hpp) products.
#pragma once
#include <cstddef>
#include <cstdint>
#if defined(__AVX2__) && defined(__FMA__) && defined(__F16C__)
#include <immintrin.h>
#endif

#include "radiosity/solve/storage/half.hpp"

namespace radiosity {

#if defined(__AVX2__) && defined(__FMA__) && defined(__F16C__)
#define HPCGI_AVX2_SUMS 1
#endif

struct Float32Values {
  using stored = float;
  static float get(const float* p, size_t k) { return p[k]; }
#ifdef HPCGI_AVX2_SUMS
  static __m256 load8(const float* p) { return _mm256_loadu_ps(p); }
#endif
};
struct Float16Values {
  using stored = uint16_t;
  static float get(const uint16_t* p, size_t k) { return half_to_float(p[k]); }
#ifdef HPCGI_AVX2_SUMS
  static __m256 load8(const uint16_t* p) {
    return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
  }
#endif
};
struct BFloat16Values {
  using stored = uint16_t;
  static float get(const uint16_t* p, size_t k) { return bfloat16_to_float(p[k]); }
#ifdef HPCGI_AVX2_SUMS
  static __m256 load8(const uint16_t* p) {
    const __m256i w = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
    return _mm256_castsi256_ps(_mm256_slli_epi32(w, 16));
  }
#endif
};

}  // namespace radiosity
