// Our best CUDA backend: three fused kernels (TeaLeaf's cg_calc_w, cg_calc_ur, cg_calc_p), each dot reduced once
// inside its kernel (warp shuffles, one double atomicAdd per block into a device scalar, accumulated in double
// also for float vectors), one 8-byte copy back per dot, no other synchronisation.
// One iteration: [w = Ap, p·w] 2 vectors, [x += αp, r -= αw, r·r] 6, [p = r + βp] 3: 11.
#include "poisson/backends.hpp"
#include "poisson/gpu_base.cuh"

namespace poisson {
namespace {

__device__ inline void block_sum_into(double v, double* out) {
  for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
  __shared__ double warp_sums[kBlock / 32];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  if (lane == 0) warp_sums[warp] = v;
  __syncthreads();
  if (warp == 0) {
    v = lane < kBlock / 32 ? warp_sums[lane] : 0.0;
    for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
    if (lane == 0) atomicAdd(out, v);
  }
}

// Grid-stride loops over the n×n interior points; idx is the padded index.
#define FOR_INTERIOR(n, s, k, idx)                                                                       \
  for (long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x, idx = 0; k < (n) * (n) &&      \
       ((idx = (k / (n) + 1) * (s) + (k % (n)) + 1), true); k += static_cast<long>(gridDim.x) * blockDim.x)

template <class T>
__global__ void __launch_bounds__(kBlock) calc_w_kernel(long n, long s, const T* __restrict__ p, T* __restrict__ w,
                                                        double* pw) {
  double acc = 0;
  FOR_INTERIOR(n, s, k, idx) {
    const T pc = p[idx];
    const T v = 4 * pc - p[idx - 1] - p[idx + 1] - p[idx - s] - p[idx + s];
    w[idx] = v;
    acc += static_cast<double>(pc) * v;
  }
  block_sum_into(acc, pw);
}

template <class T>
__global__ void __launch_bounds__(kBlock) calc_ur_kernel(long n, long s, T alpha, const T* __restrict__ p,
                                                         const T* __restrict__ w, T* __restrict__ x,
                                                         T* __restrict__ r, double* rr) {
  double acc = 0;
  FOR_INTERIOR(n, s, k, idx) {
    x[idx] += alpha * p[idx];
    const T rn = r[idx] - alpha * w[idx];
    r[idx] = rn;
    acc += static_cast<double>(rn) * rn;
  }
  block_sum_into(acc, rr);
}

template <class T>
__global__ void __launch_bounds__(kBlock) calc_p_kernel(long n, long s, T beta, const T* __restrict__ r,
                                                        T* __restrict__ p) {
  FOR_INTERIOR(n, s, k, idx) { p[idx] = r[idx] + beta * p[idx]; }
}

template <class T>
class Cuda final : public GpuBase<T> {
  using B = GpuBase<T>;

 public:
  explicit Cuda(const Config& cfg) : B(cfg, "cuda"), sum_(1) {
    int dev = 0, sms = 0;
    CUDA_CHECK(cudaGetDevice(&dev));
    CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
    const long pts = B::n_ * B::n_;
    blocks_ = static_cast<unsigned>(std::min<long>((pts + kBlock - 1) / kBlock, 8L * sms));
    CUDA_CHECK(cudaMallocHost(&host_sum_, sizeof(double)));
  }
  ~Cuda() override { cudaFreeHost(host_sum_); }

  double calc_w() override {
    zero();
    calc_w_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, B::p_.get(), B::w_.get(), sum_.get());
    CUDA_CHECK_LAUNCH();
    return fetch();
  }
  double calc_ur(double alpha) override {
    zero();
    calc_ur_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, static_cast<T>(alpha), B::p_.get(), B::w_.get(),
                                           B::x_.get(), B::r_.get(), sum_.get());
    CUDA_CHECK_LAUNCH();
    return fetch();
  }
  void calc_p(double beta) override {
    calc_p_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, static_cast<T>(beta), B::r_.get(), B::p_.get());
    CUDA_CHECK_LAUNCH();
  }
  int vectors_per_iteration() const override { return 11; }
  std::map<std::string, std::string> info() const override {
    auto i = B::info();
    i["dot"] = "fused, double accumulation";
    return i;
  }

 private:
  void zero() { CUDA_CHECK(cudaMemsetAsync(sum_.get(), 0, sizeof(double))); }
  double fetch() {
    CUDA_CHECK(cudaMemcpyAsync(host_sum_, sum_.get(), sizeof(double), cudaMemcpyDeviceToHost));
    CUDA_CHECK(cudaStreamSynchronize(0));
    return *host_sum_;
  }
  hpcgi::DeviceArray<double> sum_;
  double* host_sum_ = nullptr;
  unsigned blocks_ = 1;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_cuda(const Config& cfg) {
  return std::make_unique<Cuda<T>>(cfg);
}
template std::unique_ptr<Kernels<float>> make_cuda(const Config&);
template std::unique_ptr<Kernels<double>> make_cuda(const Config&);

}  // namespace poisson
