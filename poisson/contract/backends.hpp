// The backend factories, one per file. Only the ones this binary was built with are defined (HAVE_MPI, HAVE_CUDA).
#pragma once
#include <memory>

#include "poisson/contract/kernels.hpp"

namespace poisson {

template <class T> std::unique_ptr<Kernels<T>> make_serial(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_openmp(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_mpi(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_cublas1(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_cublas2(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_cuda(const Config& cfg);

// A backend file's factory where it is only make_unique of its class: defines NAME<T> and instantiates it for
// float and double, written once here rather than six lines in every backend file.
#define POISSON_BACKEND_FACTORY(NAME, IMPL)                                                         \
  template <class T>                                                                                 \
  std::unique_ptr<Kernels<T>> NAME(const Config& cfg) {                                              \
    return std::make_unique<IMPL<T>>(cfg);                                                           \
  }                                                                                                  \
  template std::unique_ptr<Kernels<float>> NAME(const Config&);                                      \
  template std::unique_ptr<Kernels<double>> NAME(const Config&);

}  // namespace poisson
