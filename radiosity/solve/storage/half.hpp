// 16-bit floating-point values as bit patterns: IEEE binary16 (float16) and bfloat16, rounded to nearest-even
// from float32 and widened back exactly. Written with integer operations, not _Float16 arithmetic, so that the
// kernels' loops vectorize (GCC 12 leaves a loop over _Float16 conversions scalar) and any compiler builds it.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

namespace radiosity {

template <class To, class From>
inline To bits_as(From x) {
  static_assert(sizeof(To) == sizeof(From));
  To y;
  std::memcpy(&y, &x, sizeof y);
  return y;
}

// binary16 -> float32, exact: the 15 bits of exponent and significand moved into float's place and multiplied by
// 2^112 (the difference of the exponent biases, 127 - 15), which also turns half's subnormals into float's normal
// numbers; an all-ones exponent (Inf, NaN) is made float's.
inline float half_to_float(uint16_t h) {
  const float magnitude = bits_as<float>(uint32_t(h & 0x7fffu) << 13) * 0x1p112f;
  uint32_t b = bits_as<uint32_t>(magnitude);
  if ((h & 0x7c00u) == 0x7c00u) b |= 0x7f800000u;
  return bits_as<float>(b | (uint32_t(h & 0x8000u) << 16));
}

// float32 -> binary16, round to nearest-even, overflow to Inf, NaN kept NaN.
inline uint16_t float_to_half(float f) {
  const uint32_t x = bits_as<uint32_t>(f);
  const uint16_t sign = uint16_t((x >> 16) & 0x8000u);
  const float a = std::fabs(f);
  if (std::isnan(f)) return sign | 0x7e00u;
  if (a >= 65520.0f) return sign | 0x7c00u;  // 65520 and above round to Inf
  if (a < 0x1p-14f) {
    // Subnormal half: the value in units of 2^-24, rounded to nearest-even by float's own addition.
    const float scaled = a * 0x1p24f;
    return sign | uint16_t(std::nearbyint(scaled));
  }
  const uint32_t ax = bits_as<uint32_t>(a);
  const uint32_t mant = ax & 0x7fffffu;
  const uint32_t exp = (ax >> 23) - 127 + 15;
  uint32_t h = (exp << 10) | (mant >> 13);
  const uint32_t rest = mant & 0x1fffu;  // the 13 bits dropped
  if (rest > 0x1000u || (rest == 0x1000u && (h & 1u))) ++h;  // a carry into the exponent is still right
  return sign | uint16_t(h);
}

inline float bfloat16_to_float(uint16_t b) { return bits_as<float>(uint32_t(b) << 16); }

// float32 -> bfloat16, round to nearest-even, NaN kept NaN.
inline uint16_t float_to_bfloat16(float f) {
  if (std::isnan(f)) return uint16_t((bits_as<uint32_t>(f) >> 16) | 0x40u);
  const uint32_t x = bits_as<uint32_t>(f);
  return uint16_t((x + 0x7fffu + ((x >> 16) & 1u)) >> 16);
}

}  // namespace radiosity
