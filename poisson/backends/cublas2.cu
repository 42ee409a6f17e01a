// The report's "cuBLAS 2" (§3.2): own stencil kernel, every vector operation through cuBLAS (dot, axpy, scal).
// One iteration: w = Ap (2), p·w (2), axpy x (3), axpy r (3), r·r (1), p = βp (2) then p += r (3): 16 vectors.
#include "poisson/contract/backends.hpp"
#include "poisson/backends/gpu_base.cuh"

namespace poisson {
namespace {

template <class T>
class Cublas2 final : public CublasBase<T> {
  using B = CublasBase<T>;
  using B::blas_;
  using B::dot;

 public:
  explicit Cublas2(const Config& cfg) : B(cfg, "cublas2") {}

  double calc_ur(double alpha) override {
    CUBLAS_CHECK(blas_axpy(blas_.get(), B::blas_len(), alpha, B::p_.get(), B::x_.get()));
    CUBLAS_CHECK(blas_axpy(blas_.get(), B::blas_len(), -alpha, B::w_.get(), B::r_.get()));
    return dot(B::r_.get(), B::r_.get());
  }
  void calc_p(double beta) override {
    CUBLAS_CHECK(blas_scal(blas_.get(), B::blas_len(), beta, B::p_.get()));
    CUBLAS_CHECK(blas_axpy(blas_.get(), B::blas_len(), 1.0, B::r_.get(), B::p_.get()));
  }
  int vectors_per_iteration() const override { return kVectorsCublas2; }
};

}  // namespace

POISSON_BACKEND_FACTORY(make_cublas2, Cublas2)

}  // namespace poisson
