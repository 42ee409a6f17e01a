// The backend factories, one per file. Only the ones this binary was built with are defined (HAVE_MPI, HAVE_CUDA).
#pragma once
#include <memory>

#include "poisson/kernels.hpp"

namespace poisson {

template <class T> std::unique_ptr<Kernels<T>> make_serial(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_openmp(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_mpi(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_cublas1(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_cublas2(const Config& cfg);
template <class T> std::unique_ptr<Kernels<T>> make_cuda(const Config& cfg);

}  // namespace poisson
