// How a kernel's rows are shared out, one façade for both CPU backends (pbrt-v4's ParallelFor): SerialExec runs
// all rows in one call; OpenMPExec gives each thread one contiguous block (OpenMP's static schedule) whose edges
// fall on multiples of kRowAlign rows. A kernel body takes a row range [begin, end); a reduction body returns its
// partial sums per channel; each_thread's body takes the thread's index and the thread count, for a kernel that
// shares out its rows itself (the sparse product, by entries: csr_kernels.hpp).
#pragma once
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/core/layout.hpp"

namespace radiosity {

// Thread t's rows of [0, n) out of nt threads.
inline std::pair<size_t, size_t> static_block(size_t n, int t, int nt) {
  const size_t blocks = (n + kRowAlign - 1) / kRowAlign;
  const size_t b0 = blocks * t / nt, b1 = blocks * (t + 1) / nt;
  return {std::min(n, b0 * kRowAlign), std::min(n, b1 * kRowAlign)};
}

struct SerialExec {
  int threads() const { return 1; }
  template <class Body>
  void each_thread(Body&& body) const {
    body(0, 1);
  }
  template <class Body>
  void rows(size_t n, Body&& body) const {
    body(size_t{0}, n);
  }
  template <class Body>
  Rgb reduce(size_t n, Body&& body) const {
    return body(size_t{0}, n);
  }
  template <class Body>
  Rgb reduce_max(size_t n, Body&& body) const {
    return body(size_t{0}, n);
  }
};

class OpenMPExec {
 public:
  // threads = 0: the OpenMP default (OMP_NUM_THREADS or all cores).
  explicit OpenMPExec(int threads) : threads_(threads > 0 ? threads : omp_get_max_threads()), partial_(threads_) {}
  int threads() const { return threads_; }

  template <class Body>
  void each_thread(Body&& body) const {
#pragma omp parallel num_threads(threads_)
    body(omp_get_thread_num(), omp_get_num_threads());
  }

  template <class Body>
  void rows(size_t n, Body&& body) const {
#pragma omp parallel num_threads(threads_)
    {
      const auto [b, e] = static_block(n, omp_get_thread_num(), omp_get_num_threads());
      body(b, e);
    }
  }

  // Partial sums land in one cache line per thread and are added in thread order after the region, so a run
  // gives the same bits every time for a given thread count (a `reduction` clause adds in any order).
  template <class Body>
  Rgb reduce(size_t n, Body&& body) const {
    for (Partial& p : partial_) p.v = {0, 0, 0};
#pragma omp parallel num_threads(threads_)
    {
      const int t = omp_get_thread_num();
      const auto [b, e] = static_block(n, t, omp_get_num_threads());
      partial_[t].v = body(b, e);
    }
    Rgb s{0, 0, 0};
    for (const Partial& p : partial_)
      for (int c = 0; c < 3; ++c) s[c] += p.v[c];
    return s;
  }
  // The same with the largest partial instead of the sum (an ∞-norm; NaN wins, so it is seen).
  template <class Body>
  Rgb reduce_max(size_t n, Body&& body) const {
    reduce(n, body);
    Rgb m = partial_[0].v;
    for (const Partial& p : partial_)
      for (int c = 0; c < 3; ++c)
        if (std::isnan(p.v[c]) || p.v[c] > m[c]) m[c] = p.v[c];
    return m;
  }

 private:
  struct alignas(kCacheLine) Partial {
    Rgb v;
  };
  int threads_;
  mutable std::vector<Partial> partial_;
};

// OpenMPExec on the block of rows [first, last) only (last = SIZE_MAX: to the end): its thread blocks of those
// rows, shifted by first. Runs linalg.hpp's kernels on a part of the rows: the CPU's rows of backend hybrid, an MPI
// rank's rows of backend mpi. With first = 0 and last = n it gives OpenMPExec's blocks.
class BlockExec {
 public:
  BlockExec(size_t first, size_t last, int threads) : first_(first), last_(last), ex_(threads) {}
  int threads() const { return ex_.threads(); }
  template <class Body>
  void rows(size_t n, Body&& body) const {
    const size_t end = std::min(n, last_);
    if (end <= first_) return;
    ex_.rows(end - first_, [&](size_t b, size_t e) { body(first_ + b, first_ + e); });
  }
  template <class Body>
  Rgb reduce(size_t n, Body&& body) const {
    const size_t end = std::min(n, last_);
    if (end <= first_) return {0, 0, 0};
    return ex_.reduce(end - first_, [&](size_t b, size_t e) { return body(first_ + b, first_ + e); });
  }

 private:
  size_t first_, last_;
  OpenMPExec ex_;
};

}  // namespace radiosity
