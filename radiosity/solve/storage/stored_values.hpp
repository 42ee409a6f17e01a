// How the kernels read a stored form factor (ff_matrix.hpp): as float, whatever it is stored as. get reads one
// value; load8 (AVX2) eight consecutive ones into a vector of floats: F16C's vcvtph2ps widens eight halves in one
// instruction, a bfloat16 is widened by a zero-extension and a shift; load16 (AVX-512) sixteen of them under a
// mask, the lanes masked off 0 and not read. Shared by the dense (linalg.hpp) and the sparse (csr_kernels.hpp,
// runs_kernels.hpp) products.
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
#if defined(HPCGI_AVX2_SUMS) && defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__) && defined(__BMI2__)
#define HPCGI_AVX512_SUMS 1
#endif

struct Float32Values {
  using stored = float;
  static float get(const float* p, size_t k) { return p[k]; }
#ifdef HPCGI_AVX2_SUMS
  static __m256 load8(const float* p) { return _mm256_loadu_ps(p); }
#endif
#ifdef HPCGI_AVX512_SUMS
  static __m512 load16(const float* p, __mmask16 m) { return _mm512_maskz_loadu_ps(m, p); }
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
#ifdef HPCGI_AVX512_SUMS
  static __m512 load16(const uint16_t* p, __mmask16 m) {
    return _mm512_maskz_cvtph_ps(m, _mm256_maskz_loadu_epi16(m, p));  // maskz: see BFloat16Values::load16
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
#ifdef HPCGI_AVX512_SUMS
  static __m512 load16(const uint16_t* p, __mmask16 m) {
    // the zero-masking forms: GCC 12's plain ones start from an undefined vector and warn (-Wmaybe-uninitialized)
    const __m512i w = _mm512_maskz_cvtepu16_epi32(m, _mm256_maskz_loadu_epi16(m, p));
    return _mm512_castsi512_ps(_mm512_maskz_slli_epi32(m, w, 16));
  }
#endif
};

}  // namespace radiosity
