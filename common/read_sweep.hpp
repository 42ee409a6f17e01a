// A read-only sweep over memory, the access pattern of a product that streams its matrix: the calling thread reads
// its share of an array of bytes (the split of schedule(static) over threads), as kReadStreams parts side by side,
// each line asked for prefetch_bytes ahead (0: the hardware's prefetch alone), and sums it as 64-bit integers
// (wrapping), so that any array can be read (values, columns, runs) and its sum checked after the timing. bin/stream's
// read sweep (bench/stream.cpp) and the sparse products' own byte limit (bin/radiosity solve --read-sweeps) are this
// one loop.
//
// Four streams and the prefetch were tried for issue 37, whose dense Jacobi product out-read the one-stream sweep by
// 1.28x on another day: on the 2-core EPYC VM, quiet, five alternating runs each (bin/stream --threads 2 --trials 10),
// the one-stream sweep read 28.1-40.7 GB/s best, four streams 27.8-35.6, four streams with 4096 bytes ahead 25.7-33.3.
// On the 2-core Intel VM (2026-12-06, three alternating runs each): 32.1-33.8 GB/s at 0 bytes ahead, 31.5-34.7 at
// 1 KiB, 31.2-33.9 at 4 KiB, 34.5-35.7 at 8 KiB. No gain either way, so the default asks for nothing ahead.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace hpcgi {

inline constexpr int kReadStreams = 4;

// The sum of bytes [p, p + bytes) as 64-bit words (the last word zero-padded), wrapping: what the sweep computes, for
// checking it (one thread, no timing).
inline uint64_t word_sum(const void* p, size_t bytes) {
  const auto* b = static_cast<const unsigned char*>(p);
  uint64_t s = 0;
  size_t i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t w;
    std::memcpy(&w, b + i, 8);
    s += w;
  }
  if (i < bytes) {
    uint64_t w = 0;
    std::memcpy(&w, b + i, bytes - i);
    s += w;
  }
  return s;
}

// Thread t of nt: its share of [p, p + bytes) (whole 8-byte words; the last thread takes the remainder), read as
// kReadStreams parts side by side, a 64-byte line of each a pass. The shares' sums add up to word_sum(p, bytes).
inline uint64_t read_share(const void* p, size_t bytes, int t, int nt, size_t prefetch_bytes = 0) {
  typedef uint64_t Line __attribute__((vector_size(64)));  // a line's 8 words (AVX-512: one register; AVX2: two)
  constexpr size_t kLine = 64;
  const size_t words = bytes / 8, q = words / size_t(nt), r = words % size_t(nt), tt = size_t(t);
  const size_t begin = 8 * (tt * q + std::min(tt, r)), size = 8 * (q + (tt < r ? 1 : 0));
  const auto* b = static_cast<const unsigned char*>(p) + begin;
  const size_t len = size / kReadStreams / kLine * kLine;  // bytes of each stream, whole lines
  Line s[kReadStreams] = {};  // partial sums per lane: a plain sum is one chain of dependent adds
  for (size_t i = 0; i < len; i += kLine)
    for (int k = 0; k < kReadStreams; ++k) {
      const unsigned char* line = b + size_t(k) * len + i;
      if (prefetch_bytes > 0) __builtin_prefetch(line + prefetch_bytes);  // (past the share: a prefetch never faults)
      Line v;
      std::memcpy(&v, line, sizeof v);
      s[k] += v;
    }
  uint64_t sum = word_sum(b + kReadStreams * len, size - kReadStreams * len);  // what the streams left
  for (int k = 0; k < kReadStreams; ++k)
    for (int l = 0; l < 8; ++l) sum += s[k][l];
  if (tt + 1 == size_t(nt)) sum += word_sum(b + size, bytes - 8 * words);  // the bytes past the last whole word
  return sum;
}

}  // namespace hpcgi
