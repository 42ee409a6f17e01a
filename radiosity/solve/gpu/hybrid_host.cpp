#include "radiosity/solve/gpu/hybrid_host.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "radiosity/solve/host/exec.hpp"
#include "radiosity/solve/core/layout.hpp"
#include "radiosity/solve/host/linalg.hpp"

namespace radiosity {

size_t gpu_rows(size_t n, double d) {
  const double dn = d * double(n);
  if (!(dn > 0)) return 0;  // d = 0 (or n = 0): no row on the GPU
  const double rows = std::ceil(dn - 1e-9);
  // 0 < d n <= 1e-9: the hair taken off above leaves 0, but ⌈d n⌉ is 1.
  return std::min(n, rows < 1 ? size_t(1) : static_cast<size_t>(rows));
}

template <class T>
struct HostRows<T>::Impl {
  Impl(const System& sys, size_t first_row, int vectors, int threads)
      : n(sys.n), first(first_row), F(dense_float32(sys)), ex(first_row, SIZE_MAX, threads), rho(sys.n), e(sys.n) {
    put(rho, sys.reflectivity);
    put(e, sys.emission);
    vec.reserve(vectors);
    for (int k = 0; k < vectors; ++k) {
      vec.emplace_back(n);
      std::fill(vec.back().data(0), vec.back().data(0) + 3 * n, T(0));
    }
  }
  void put(Aos<T>& dst, const std::vector<Rgb>& src) {
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) dst(i, c) = T(src[i][c]);
  }

  size_t n, first;
  const float* F;
  BlockExec ex;  // rows [first, n)
  Aos<T> rho, e;
  std::vector<Aos<T>> vec;
};

template <class T>
HostRows<T>::HostRows(const System& sys, size_t first, int vectors, int threads)
    : impl_(std::make_unique<Impl>(sys, first, vectors, threads)) {}
template <class T>
HostRows<T>::~HostRows() = default;

template <class T>
int HostRows<T>::threads() const {
  return impl_->ex.threads();
}
template <class T>
T* HostRows<T>::data(int v) {
  return impl_->vec.at(v).data(0);
}
template <class T>
void HostRows<T>::load(int v, const std::vector<Rgb>& x) {
  impl_->put(impl_->vec.at(v), x);
}
template <class T>
void HostRows<T>::store(int v, std::vector<Rgb>& x) const {
  const Aos<T>& src = impl_->vec.at(v);
  for (size_t i = impl_->first; i < impl_->n; ++i)
    for (int c = 0; c < 3; ++c) x[i][c] = src(i, c);
}
template <class T>
void HostRows<T>::matvec(int y, int x, T a, T c, T d) {
  Impl& m = *impl_;
  affine_matvec(m.ex, m.F, m.vec.at(x), m.vec.at(y), m.rho, m.e, a, c, d);
}
template <class T>
Rgb HostRows<T>::dot(int x, int y) const {
  return radiosity::dot(impl_->ex, impl_->vec.at(x), impl_->vec.at(y));
}
template <class T>
Rgb HostRows<T>::dist2(int x, int y) const {
  return radiosity::dist2(impl_->ex, impl_->vec.at(x), impl_->vec.at(y));
}
template <class T>
void HostRows<T>::axpby(int y, const Rgb& a, int x, const Rgb& b) {
  radiosity::axpby(impl_->ex, impl_->vec.at(y), a, impl_->vec.at(x), b);
}
template <class T>
void HostRows<T>::copy(int y, int x) {
  radiosity::copy(impl_->ex, impl_->vec.at(y), impl_->vec.at(x));
}

template class HostRows<float>;
template class HostRows<double>;

}  // namespace radiosity
