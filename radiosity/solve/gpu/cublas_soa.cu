// Backend `cublas`: the report's CUDA column of Table 4.4 (§3.8.1): one array per colour channel on the GPU, the
// product by cuBLAS, one cublasSgemv per channel (three passes over F), as the report did; with `fused`, one
// cublasSgemm whose three columns are the channels, which reads F once. Dots by cublasSdot, one per channel, as the
// report; the elementwise rest (ρ ⊙ and the affine terms, axpby, x - y) by own kernels, one launch for all three
// channels.
//
// cuBLAS keeps matrices by columns: F stored by rows is Fᵀ to it (lda = n), so F x is the transposed product
// (CUBLAS_OP_T). A channel is a column of length stride (n rounded up to 32), so the three channels of a slot are
// an n × 3 matrix with ld = stride for the fused Sgemm.
//
// F in csr or compressed: the product by sparse_device.cuh (cuSPARSE's SpMM for csr float32 in float, the three
// channels as one n × 3 column-major right-hand side with ld = stride; our warp-per-row kernel otherwise), which
// reads F once for the three channels with or without `fused`; the dots as above.
//
// Double working precision: cuBLAS has no product of a float matrix with a double vector, so F is widened to
// double on the GPU once (chunk by chunk through a float staging buffer) and Dgemv/Dgemm/Ddot run on it: the
// CPU backends' arithmetic, double(F_ij)·x_j, all by cuBLAS, at the price of 8n² bytes of memory and traffic per
// pass instead of 4n² (matrix_bytes says so).
#include <climits>
#include <type_traits>

#include <optional>

#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/gpu/device_kernels.cuh"
#include "radiosity/solve/gpu/sparse_device.cuh"

namespace radiosity {
namespace {

using gpu::DeviceClock;
using gpu::kBlock;

constexpr size_t kWidenChunk = size_t(16) << 20;        // floats of F widened at a time (64 MiB of staging)
constexpr double kBlasWorkspace = double(64 << 20);      // what cuBLAS may allocate for itself, kept free
constexpr size_t stride_for(size_t n) { return (n + 31) / 32 * 32; }

// Typed cuBLAS calls: S for float, D for double. Scalars are device pointers (CUBLAS_POINTER_MODE_DEVICE).
cublasStatus_t gemv(cublasHandle_t h, int n, const float* one, const float* F, const float* x, const float* zero,
                    float* y) {
  return cublasSgemv(h, CUBLAS_OP_T, n, n, one, F, n, x, 1, zero, y, 1);
}
cublasStatus_t gemv(cublasHandle_t h, int n, const double* one, const double* F, const double* x, const double* zero,
                    double* y) {
  return cublasDgemv(h, CUBLAS_OP_T, n, n, one, F, n, x, 1, zero, y, 1);
}
// Y (n × 3, ld) = F X (n × 3, ld).
cublasStatus_t gemm(cublasHandle_t h, int n, int ld, const float* one, const float* F, const float* X,
                    const float* zero, float* Y) {
  return cublasSgemm(h, CUBLAS_OP_T, CUBLAS_OP_N, n, 3, n, one, F, n, X, ld, zero, Y, ld);
}
cublasStatus_t gemm(cublasHandle_t h, int n, int ld, const double* one, const double* F, const double* X,
                    const double* zero, double* Y) {
  return cublasDgemm(h, CUBLAS_OP_T, CUBLAS_OP_N, n, 3, n, one, F, n, X, ld, zero, Y, ld);
}
cublasStatus_t blas_dot(cublasHandle_t h, int n, const float* x, const float* y, float* out) {
  return cublasSdot(h, n, x, 1, y, 1, out);
}
cublasStatus_t blas_dot(cublasHandle_t h, int n, const double* x, const double* y, double* out) {
  return cublasDdot(h, n, x, 1, y, 1, out);
}

// Each kernel below: channel blockIdx.y (it starts at blockIdx.y · stride), its n patches by a grid-stride loop.

// y = a·x + c·ρ ⊙ p + d·e, where p = F x came from cuBLAS.
template <class T>
__global__ void __launch_bounds__(kBlock)
    soa_affine_kernel(size_t n, size_t stride, const T* __restrict__ x, const T* __restrict__ p,
                      const T* __restrict__ rho, const T* __restrict__ e, T* __restrict__ y, T a, T c, T d) {
  for (size_t i = blockIdx.x * size_t(kBlock) + threadIdx.x; i < n; i += size_t(gridDim.x) * kBlock) {
    const size_t k = blockIdx.y * stride + i;
    y[k] = a * x[k] + c * rho[k] * p[k] + d * e[k];
  }
}

template <class T>
__global__ void __launch_bounds__(kBlock) soa_sub_kernel(size_t n, size_t stride, const T* __restrict__ x,
                                                         const T* __restrict__ y, T* __restrict__ out) {
  for (size_t i = blockIdx.x * size_t(kBlock) + threadIdx.x; i < n; i += size_t(gridDim.x) * kBlock) {
    const size_t k = blockIdx.y * stride + i;
    out[k] = x[k] - y[k];
  }
}

template <class T>
__global__ void __launch_bounds__(kBlock) soa_axpby_kernel(size_t n, size_t stride, T a0, T a1, T a2, const T* x,
                                                           T b0, T b1, T b2, T* y) {  // x may be y
  const T a = blockIdx.y == 0 ? a0 : blockIdx.y == 1 ? a1 : a2;
  const T b = blockIdx.y == 0 ? b0 : blockIdx.y == 1 ? b1 : b2;
  for (size_t i = blockIdx.x * size_t(kBlock) + threadIdx.x; i < n; i += size_t(gridDim.x) * kBlock) {
    const size_t k = blockIdx.y * stride + i;
    y[k] = a * x[k] + b * y[k];
  }
}

__global__ void __launch_bounds__(kBlock) widen_kernel(size_t count, const float* __restrict__ in,
                                                       double* __restrict__ out) {
  for (size_t k = blockIdx.x * size_t(kBlock) + threadIdx.x; k < count; k += size_t(gridDim.x) * kBlock)
    out[k] = in[k];
}

template <class T>
class CublasSoa final : public gpu::DeviceKernels<T> {
 public:
  // Device memory the constructor allocates; dense: with F (as T), else sparse_device.cuh's.
  static double bytes_needed(const System& sys, int vectors) {
    const size_t n = sys.n;
    const double nn = sparse(sys) ? 0.0 : double(n) * double(n);
    const double staging = std::is_same_v<T, double> ? 4.0 * std::min(nn, double(kWidenChunk)) : 0.0;
    return sizeof(T) * nn + staging + double(vectors + 3) * 3.0 * double(stride_for(n)) * sizeof(T) +
           5.0 * sizeof(T) + kBlasWorkspace +
           (sparse(sys) ? gpu::SparseDevice<T>::bytes_needed(sys.matrix, 3 * stride_for(n)) : 0.0);
  }
  static bool sparse(const System& sys) { return sys.matrix.n && sys.matrix.storage != FFStorage::dense; }

  CublasSoa(const System& sys, bool fused, int vectors)
      : n_(sys.n), stride_(stride_for(sys.n)), fused_(fused), blas_(this->stream_.get(), CUBLAS_POINTER_MODE_DEVICE),
        F_(sparse(sys) ? 1 : sys.n * sys.n), rho_(3 * stride_), e_(3 * stride_), p_(3 * stride_), consts_(2), res_(3), host_res_(3) {
    if (sparse(sys)) {
      sparse_.emplace(sys.matrix, stride_, 1, 3 * stride_, s(), this->clock_);
      matrix_bytes_ = gpu::SparseDevice<T>::matrix_bytes(sys.matrix);
    } else {
      upload_matrix(dense_float32(sys));
    }
    const T consts[2] = {1, 0};
    CUDA_CHECK(cudaMemcpyAsync(consts_.get(), consts, sizeof consts, cudaMemcpyHostToDevice, s()));
    put(rho_.get(), sys.reflectivity);  // waits, so consts may go too
    put(e_.get(), sys.emission);
    CUDA_CHECK(cudaMemsetAsync(p_.get(), 0, 3 * stride_ * sizeof(T), s()));
    for (int v = 0; v < vectors; ++v) {
      vec_.push_back(std::make_unique<hpcgi::DeviceArray<T>>(3 * stride_));
      CUDA_CHECK(cudaMemsetAsync(vec_.back()->get(), 0, 3 * stride_ * sizeof(T), s()));  // the padding stays 0
    }
  }

  void upload(int v, const std::vector<Rgb>& x) override { put(slot(v), x); }
  void download(int v, std::vector<Rgb>& x) override {
    std::vector<T> h(3 * stride_);
    CUDA_CHECK(cudaMemcpyAsync(h.data(), slot(v), h.size() * sizeof(T), cudaMemcpyDeviceToHost, s()));
    CUDA_CHECK(cudaStreamSynchronize(s()));
    x.resize(n_);
    for (size_t i = 0; i < n_; ++i)
      for (int c = 0; c < 3; ++c) x[i][c] = h[c * stride_ + i];
  }

  void matvec(int y, int x, double a, double c, double d) override {
    const T* X = slot(x);
    T* P = p_.get();
    if (sparse_) {
      sparse_->matvec(X, slot(y), rho_.get(), e_.get(), T(a), T(c), T(d));
      return;
    }
    this->clock_.timed(DeviceClock::kCompute, [&] {
      if (fused_) {
        CUBLAS_CHECK(gemm(blas_.get(), int(n_), int(stride_), one(), F_.get(), X, zero(), P));
      } else {
        for (int ch = 0; ch < 3; ++ch)
          CUBLAS_CHECK(gemv(blas_.get(), int(n_), one(), F_.get(), X + ch * stride_, zero(), P + ch * stride_));
      }
      soa_affine_kernel<T><<<grid(), kBlock, 0, s()>>>(n_, stride_, X, P, rho_.get(), e_.get(), slot(y), T(a), T(c),
                                                       T(d));
      CUDA_CHECK_LAUNCH();
    });
  }
  Rgb dot(int x, int y) override { return dots(slot(x), slot(y)); }
  Rgb dist2(int x, int y) override {
    T* P = p_.get();  // free between products
    this->clock_.timed(DeviceClock::kCompute, [&] {
      soa_sub_kernel<T><<<grid(), kBlock, 0, s()>>>(n_, stride_, slot(x), slot(y), P);
      CUDA_CHECK_LAUNCH();
    });
    return dots(P, P);
  }
  void axpby(int y, const Rgb& a, int x, const Rgb& b) override {
    this->clock_.timed(DeviceClock::kCompute, [&] {
      soa_axpby_kernel<T><<<grid(), kBlock, 0, s()>>>(n_, stride_, T(a[0]), T(a[1]), T(a[2]), slot(x), T(b[0]),
                                                      T(b[1]), T(b[2]), slot(y));
      CUDA_CHECK_LAUNCH();
    });
  }
  void copy(int y, int x) override {
    this->clock_.timed(DeviceClock::kCompute, [&] {
      CUDA_CHECK(cudaMemcpyAsync(slot(y), slot(x), 3 * stride_ * sizeof(T), cudaMemcpyDeviceToDevice, s()));
    });
  }
  int threads() const override { return 1; }
  double matrix_bytes() const override {
    if (sparse_) return matrix_bytes_;
    return (fused_ ? 1.0 : 3.0) * sizeof(T) * double(n_) * double(n_);
  }
  std::map<std::string, std::string> info() const override {
    auto i = gpu::DeviceKernels<T>::info();
    const bool f = std::is_same_v<T, float>;
    i["product"] = fused_ ? (f ? "cublasSgemm, 3 columns" : "cublasDgemm, 3 columns, F widened to double")
                          : (f ? "cublasSgemv per channel" : "cublasDgemv per channel, F widened to double");
    if (sparse_) i["product"] = sparse_->product();
    i["dot"] = f ? "cublasSdot per channel" : "cublasDdot per channel";
    return i;
  }

 private:
  cudaStream_t s() const { return this->stream_.get(); }
  T* slot(int v) { return vec_.at(v)->get(); }
  const T* one() const { return consts_.get(); }
  const T* zero() const { return consts_.get() + 1; }
  dim3 grid() const { return dim3(gpu::grid_for(n_, 1024), 3); }

  // F (float, by rows) into F_, in T.
  void upload_matrix(const float* F) {
    const size_t total = n_ * n_;
    this->clock_.timed(DeviceClock::kUpload, [&] {
      if constexpr (std::is_same_v<T, float>) {
        CUDA_CHECK(cudaMemcpyAsync(F_.get(), F, total * sizeof(float), cudaMemcpyHostToDevice, s()));
      } else {
        hpcgi::DeviceArray<float> staging(std::min(total, kWidenChunk));
        for (size_t k0 = 0; k0 < total; k0 += kWidenChunk) {
          const size_t m = std::min(kWidenChunk, total - k0);
          CUDA_CHECK(cudaMemcpyAsync(staging.get(), F + k0, m * sizeof(float), cudaMemcpyHostToDevice, s()));
          widen_kernel<<<gpu::grid_for(m, 4096), kBlock, 0, s()>>>(m, staging.get(), F_.get() + k0);
          CUDA_CHECK_LAUNCH();
        }
        CUDA_CHECK(cudaStreamSynchronize(s()));  // before the staging buffer is freed
      }
    });
  }

  // A host vector into a device slot, converted to T, the padding 0; waits, so the staging vector may go.
  void put(T* dst, const std::vector<Rgb>& src) {
    std::vector<T> h(3 * stride_, T(0));
    for (size_t i = 0; i < n_; ++i)
      for (int c = 0; c < 3; ++c) h[c * stride_ + i] = T(src[i][c]);
    CUDA_CHECK(cudaMemcpyAsync(dst, h.data(), h.size() * sizeof(T), cudaMemcpyHostToDevice, s()));
    CUDA_CHECK(cudaStreamSynchronize(s()));
  }

  // One cuBLAS dot per channel into device memory, then the three in one copy.
  Rgb dots(const T* x, const T* y) {
    this->clock_.timed(DeviceClock::kCompute, [&] {
      for (int ch = 0; ch < 3; ++ch)
        CUBLAS_CHECK(blas_dot(blas_.get(), int(n_), x + ch * stride_, y + ch * stride_, res_.get() + ch));
    });
    this->clock_.timed(DeviceClock::kTransfer, [&] {
      CUDA_CHECK(cudaMemcpyAsync(host_res_.get(), res_.get(), 3 * sizeof(T), cudaMemcpyDeviceToHost, s()));
    });
    this->clock_.moved(3 * sizeof(T));
    CUDA_CHECK(cudaStreamSynchronize(s()));
    const T* h = host_res_.get();
    return {double(h[0]), double(h[1]), double(h[2])};
  }

  size_t n_, stride_;
  bool fused_;
  hpcgi::BlasHandle blas_;  // scalars on the device: a dot stays there until a slot's three are fetched
  hpcgi::DeviceArray<T> F_, rho_, e_, p_, consts_, res_;
  gpu::PinnedArray<T> host_res_;
  std::vector<std::unique_ptr<hpcgi::DeviceArray<T>>> vec_;
  std::optional<gpu::SparseDevice<T>> sparse_;  // F in csr or compressed (then F_ is unused)
  double matrix_bytes_ = 0;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_cublas(const System& sys, const SolveConfig& cfg, int vectors) {
  const std::string who = gpu::who("cublas", sys, cfg);
  hpcgi::require_gpu(who);
  if (stride_for(sys.n) > size_t(INT_MAX)) throw hpcgi::UsageError(who + ": too many patches for cuBLAS's int sizes");
  if (!CublasSoa<T>::sparse(sys) && !dense_float32(sys))
    throw hpcgi::UsageError(who + ": dense form factors are read as the file's float32 values");
  hpcgi::require_device_memory(who, CublasSoa<T>::bytes_needed(sys, vectors));
  return std::make_unique<CublasSoa<T>>(sys, cfg.fused, vectors);
}
template std::unique_ptr<Kernels<float>> make_cublas(const System&, const SolveConfig&, int);
template std::unique_ptr<Kernels<double>> make_cublas(const System&, const SolveConfig&, int);

}  // namespace radiosity
