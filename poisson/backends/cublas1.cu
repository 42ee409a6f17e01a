// The report's "cuBLAS 1" (§3.2): own stencil and axpby kernels, cuBLAS for the dot products only.
// One iteration: w = Ap (2 vectors), p·w (2), x = x + αp (3), r = r - αw (3), r·r (1), p = r + βp (3): 14.
#include "poisson/contract/backends.hpp"
#include "poisson/backends/gpu_base.cuh"

namespace poisson {
namespace {

// y = a x + b y over the whole padded array (ghosts are zero and stay zero).
template <class T>
__global__ void axpby_kernel(long len, T a, const T* __restrict__ x, T b, T* __restrict__ y) {
  const long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x;
  if (k < len) y[k] = a * x[k] + b * y[k];
}

template <class T>
class Cublas1 final : public CublasBase<T> {
  using B = CublasBase<T>;
  using B::dot;

 public:
  explicit Cublas1(const Config& cfg) : B(cfg, "cublas1") {}

  double calc_ur(double alpha) override {
    axpby(alpha, B::p_.get(), 1.0, B::x_.get());
    axpby(-alpha, B::w_.get(), 1.0, B::r_.get());
    return dot(B::r_.get(), B::r_.get());
  }
  void calc_p(double beta) override { axpby(1.0, B::r_.get(), beta, B::p_.get()); }
  int vectors_per_iteration() const override { return kVectorsCublas1; }

 private:
  void axpby(double a, const T* x, double b, T* y) {
    const long len = B::size_;
    axpby_kernel<T><<<static_cast<unsigned>((len + kBlock - 1) / kBlock), kBlock>>>(len, static_cast<T>(a), x,
                                                                                      static_cast<T>(b), y);
    CUDA_CHECK_LAUNCH();
  }
};

}  // namespace

POISSON_BACKEND_FACTORY(make_cublas1, Cublas1)

}  // namespace poisson
