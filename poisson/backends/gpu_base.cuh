// What the three CUDA backends share: the vectors on the device in the padded (N+2)×(N+2) layout (zero ghost
// rows and columns, so the stencil needs no branches and whole-array BLAS calls see zeros there), the stencil
// kernel, and the host-side checks after the solve (true residual, error, solution).
#pragma once
#include <algorithm>
#include <climits>
#include <cmath>
#include <string>
#include <vector>

#include "common/cuda_check.cuh"
#include "poisson/contract/kernels.hpp"
#include "poisson/contract/stencil.hpp"

namespace poisson {

inline constexpr int kBlock = 256;

// out = A in on the interior points (one thread per point, consecutive threads along x).
template <class T>
__global__ void stencil_kernel(long n, long s, const T* __restrict__ in, T* __restrict__ out) {
  const long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x;
  if (k >= n * n) return;
  const long idx = (k / n + 1) * s + (k % n) + 1;
  out[idx] = five_point_at(in, s, idx);
}

// Base is Kernels<T>, or OneSweepKernels<T> for a backend that also runs the one-sweep variant.
template <class T, class Base = Kernels<T>>
class GpuBase : public Base {
 protected:
  GpuBase(const Config& cfg, const std::string& name)
      : n_((hpcgi::require_gpu("backend " + name), cfg.n)), s_(cfg.n + 2), size_(s_ * s_),
        x_((check_fits(name), size_)), r_(size_), p_(size_), w_(size_), b_(size_), name_(name) {
    const GridTable g{Grid{n_}};
    std::vector<T> b(size_, T(0));
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) b[(j + 1) * s_ + i + 1] = static_cast<T>(g.b(i, j));
    bb_ = 0;
    for (T v : b) bb_ += static_cast<double>(v) * v;
    host_b_ = std::move(b);
    CUDA_CHECK(cudaMemcpy(b_.get(), host_b_.data(), size_ * sizeof(T), cudaMemcpyHostToDevice));
    CUDA_CHECK(cudaMemset(w_.get(), 0, size_ * sizeof(T)));
  }

  // x = 0, r = p = b (device copies), r·r from the host copy of b.
  double init_vectors() {
    CUDA_CHECK(cudaMemset(x_.get(), 0, size_ * sizeof(T)));
    CUDA_CHECK(cudaMemcpy(r_.get(), b_.get(), size_ * sizeof(T), cudaMemcpyDeviceToDevice));
    CUDA_CHECK(cudaMemcpy(p_.get(), b_.get(), size_ * sizeof(T), cudaMemcpyDeviceToDevice));
    return bb_;
  }

  void stencil(const T* in, T* out) {
    const long pts = n_ * n_;
    stencil_kernel<T><<<static_cast<unsigned>((pts + kBlock - 1) / kBlock), kBlock>>>(n_, s_, in, out);
    CUDA_CHECK_LAUNCH();
  }

  int blas_len() const { return static_cast<int>(size_); }

 public:
  double init() override { return init_vectors(); }

  double true_residual2() override {
    const std::vector<T> x = host_x();
    double sum = 0;
    for (long j = 1; j <= n_; ++j)
      for (long i = 1; i <= n_; ++i) {
        const long k = j * s_ + i;
        const double ax = five_point<double>(4.0, x[k], x[k - 1], x[k + 1], x[k - s_], x[k + s_]);
        const double d = host_b_[k] - ax;
        sum += d * d;
      }
    return sum;
  }

  double error_inf() override {
    const std::vector<T> x = host_x();
    const GridTable g{Grid{n_}};
    double e = 0;
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i)
        e = std::max(e, std::abs(static_cast<double>(x[(j + 1) * s_ + i + 1]) - g.u(i, j)));
    return e;
  }

  std::vector<double> solution() override {
    const std::vector<T> x = host_x();
    std::vector<double> out(n_ * n_);
    for (long j = 0; j < n_; ++j)
      for (long i = 0; i < n_; ++i) out[j * n_ + i] = x[(j + 1) * s_ + i + 1];
    return out;
  }

  std::map<std::string, std::string> info() const override {
    auto i = hpcgi::gpu_info();
    i["threads"] = "1";
    return i;
  }

 private:
  void check_fits(const std::string& name) const {
    if (size_ > INT_MAX) throw hpcgi::UsageError("backend " + name + ": N is too large for 32-bit BLAS lengths");
    hpcgi::require_device_memory("backend " + name + " at N = " + std::to_string(n_),
                                 5.0 * static_cast<double>(size_) * sizeof(T));
  }
  std::vector<T> host_x() const {
    std::vector<T> x(size_);
    CUDA_CHECK(cudaMemcpy(x.data(), x_.get(), size_ * sizeof(T), cudaMemcpyDeviceToHost));
    return x;
  }

 protected:
  long n_, s_, size_;
  hpcgi::DeviceArray<T> x_, r_, p_, w_, b_;
  std::string name_;
  std::vector<T> host_b_;
  double bb_ = 0;
};

// Typed cuBLAS wrappers: the D routines for double, the S routines for float.
inline cublasStatus_t blas_dot(cublasHandle_t h, int n, const double* x, const double* y, double* out) {
  return cublasDdot(h, n, x, 1, y, 1, out);
}
inline cublasStatus_t blas_dot(cublasHandle_t h, int n, const float* x, const float* y, double* out) {
  float f = 0;
  cublasStatus_t st = cublasSdot(h, n, x, 1, y, 1, &f);
  *out = f;
  return st;
}
inline cublasStatus_t blas_axpy(cublasHandle_t h, int n, double a, const double* x, double* y) {
  return cublasDaxpy(h, n, &a, x, 1, y, 1);
}
inline cublasStatus_t blas_axpy(cublasHandle_t h, int n, double a, const float* x, float* y) {
  const float af = static_cast<float>(a);
  return cublasSaxpy(h, n, &af, x, 1, y, 1);
}
inline cublasStatus_t blas_scal(cublasHandle_t h, int n, double a, double* x) { return cublasDscal(h, n, &a, x, 1); }
inline cublasStatus_t blas_scal(cublasHandle_t h, int n, double a, float* x) {
  const float af = static_cast<float>(a);
  return cublasSscal(h, n, &af, x, 1);
}

// GpuBase with a cuBLAS handle and the dot through it: the report's two cuBLAS backends (cublas1, cublas2).
template <class T>
class CublasBase : public GpuBase<T> {
 public:
  CublasBase(const Config& cfg, const std::string& name) : GpuBase<T>(cfg, name) {}
  // w = Ap with the own stencil kernel, then p·w by cuBLAS: the same in cuBLAS 1 and cuBLAS 2.
  double calc_w() override {
    this->stencil(this->p_.get(), this->w_.get());
    return dot(this->p_.get(), this->w_.get());
  }
  std::map<std::string, std::string> info() const override {
    auto i = GpuBase<T>::info();
    i["dot"] = sizeof(T) == 8 ? "cublasDdot" : "cublasSdot";
    return i;
  }

 protected:
  double dot(const T* a, const T* b) {
    double out = 0;
    CUBLAS_CHECK(blas_dot(blas_.get(), this->blas_len(), a, b, &out));
    return out;
  }
  hpcgi::BlasHandle blas_;
};

}  // namespace poisson
