// The two memory layouts of the radiosity vectors, behind one accessor, so that every kernel and every solver is
// written once for both (pbrt-v4's lesson). v(i, c) is patch i, channel c; the hot loops take v.data(c) and step
// kStep (a compile-time constant, so the compiler sees unit-stride or 3-interleaved loads and vectorizes them):
//   Aos: one {r, g, b} record per patch, RRV's Color (report §3.7, Figure 3.2);
//   Soa: one contiguous array per channel, what BLAS (cuBLAS sgemv/sdot, report §3.8.1) takes;
//   Grey: one array, the single channel of a scene whose reflectivities and emissions are all grey: the three
//         channels would be three copies of one solve, so it is solved once (kChannels = 1; v(i, c) is the
//         same value for every c, so a caller reading r, g, b gets three equal channels).
// The memory is left uninitialised on purpose: the backend's threads touch their own rows first (first-touch
// placement on multi-socket nodes).
#pragma once
#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>

namespace radiosity {

inline constexpr size_t kCacheLine = 64;
// A thread's share of rows starts on a multiple of this: 16 rows of either layout in either precision span whole
// cache lines (AOS float 192 bytes, SOA float 64), so no two threads ever write the same line (no false sharing).
inline constexpr size_t kRowAlign = 16;

inline size_t round_up(size_t x, size_t m) { return (x + m - 1) / m * m; }

template <class T>
class AlignedBuffer {
 public:
  explicit AlignedBuffer(size_t count) {
    const size_t bytes = round_up(count > 0 ? count * sizeof(T) : 1, kCacheLine);
    p_.reset(static_cast<T*>(std::aligned_alloc(kCacheLine, bytes)));
    if (!p_) throw std::bad_alloc();
  }
  T* get() const { return p_.get(); }

 private:
  struct Free {
    void operator()(T* p) const { std::free(p); }
  };
  std::unique_ptr<T, Free> p_;
};

template <class T>
class Aos {
 public:
  using value_type = T;
  static constexpr size_t kStep = 3;
  static constexpr int kChannels = 3;
  explicit Aos(size_t n) : n_(n), buf_(3 * n) {}
  size_t size() const { return n_; }
  T* data(int c) { return buf_.get() + c; }
  const T* data(int c) const { return buf_.get() + c; }
  T& operator()(size_t i, int c) { return buf_.get()[3 * i + c]; }
  T operator()(size_t i, int c) const { return buf_.get()[3 * i + c]; }

 private:
  size_t n_;
  AlignedBuffer<T> buf_;
};

template <class T>
class Soa {
 public:
  using value_type = T;
  static constexpr size_t kStep = 1;
  static constexpr int kChannels = 3;
  // Each channel starts on a cache line, so the row blocks of every channel are aligned alike.
  explicit Soa(size_t n) : n_(n), stride_(round_up(n, kRowAlign)), buf_(3 * stride_) {}
  size_t size() const { return n_; }
  T* data(int c) { return buf_.get() + c * stride_; }
  const T* data(int c) const { return buf_.get() + c * stride_; }
  T& operator()(size_t i, int c) { return buf_.get()[c * stride_ + i]; }
  T operator()(size_t i, int c) const { return buf_.get()[c * stride_ + i]; }

 private:
  size_t n_, stride_;
  AlignedBuffer<T> buf_;
};

template <class T>
class Grey {
 public:
  using value_type = T;
  static constexpr size_t kStep = 1;
  static constexpr int kChannels = 1;
  explicit Grey(size_t n) : n_(n), buf_(n) {}
  size_t size() const { return n_; }
  T* data(int) { return buf_.get(); }
  const T* data(int) const { return buf_.get(); }
  T& operator()(size_t i, int) { return buf_.get()[i]; }
  T operator()(size_t i, int) const { return buf_.get()[i]; }

 private:
  size_t n_;
  AlignedBuffer<T> buf_;
};

}  // namespace radiosity
