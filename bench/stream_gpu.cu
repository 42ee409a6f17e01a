// bin/stream --device gpu: STREAM's triad and a read-only sweep in the GPU's memory (bench/stream_gpu.hpp). The
// limit every GPU number of the project is judged by: a kernel that streams F or the CG vectors cannot beat it.
#include <algorithm>
#include <vector>

#include "common/cuda_check.cuh"
#include "bench/stream_gpu.hpp"

namespace hpcgi {
namespace {

constexpr int kThreads = 256;

__global__ void __launch_bounds__(kThreads) fill_kernel(long n, double* a, double* b, double* c) {
  for (long i = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x; i < n; i += static_cast<long>(gridDim.x) * blockDim.x) {
    a[i] = 0.0;
    b[i] = 1.0;
    c[i] = 2.0;
  }
}

__global__ void __launch_bounds__(kThreads) triad_kernel(long n, double s, double* __restrict__ a,
                                                         const double* __restrict__ b, const double* __restrict__ c) {
  for (long i = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x; i < n; i += static_cast<long>(gridDim.x) * blockDim.x)
    a[i] = b[i] + s * c[i];
}

// Σ a: each thread its grid-stride share, then the block's sum (warp shuffles, warp sums in shared memory), one
// double atomicAdd per block. The sums of 7s are integers below 2^53, exact in any order.
__global__ void __launch_bounds__(kThreads) read_kernel(long n, const double* __restrict__ a, double* sum) {
  double v = 0;
  for (long i = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x; i < n; i += static_cast<long>(gridDim.x) * blockDim.x)
    v += a[i];
  for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
  __shared__ double warp_sums[kThreads / 32];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  if (lane == 0) warp_sums[warp] = v;
  __syncthreads();
  if (warp == 0) {
    v = lane < kThreads / 32 ? warp_sums[lane] : 0.0;
    for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
    if (lane == 0) atomicAdd(sum, v);
  }
}

class Event {
 public:
  Event() { CUDA_CHECK(cudaEventCreate(&e_)); }
  ~Event() { cudaEventDestroy(e_); }
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  cudaEvent_t get() const { return e_; }

 private:
  cudaEvent_t e_{};
};

double seconds_between(const Event& a, const Event& b) {
  CUDA_CHECK(cudaEventSynchronize(b.get()));
  float ms = 0;
  CUDA_CHECK(cudaEventElapsedTime(&ms, a.get(), b.get()));
  return 1e-3 * ms;
}

}  // namespace

GpuSweeps gpu_sweeps(long n, int trials) {
  require_gpu("bin/stream --device gpu");
  require_device_memory("bin/stream --device gpu --size " + std::to_string(n), 3.0 * sizeof(double) * n + 8);
  GpuSweeps out;
  out.info = gpu_info();
  int dev = 0, sms = 0;
  CUDA_CHECK(cudaGetDevice(&dev));
  CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
  // Enough resident blocks to keep every SM's memory pipeline full, each thread striding over the arrays.
  const long want = (n + kThreads - 1) / kThreads;
  const unsigned blocks = static_cast<unsigned>(std::min<long>(want, 16L * sms));
  DeviceArray<double> a(n), b(n), c(n), sum(1);
  fill_kernel<<<blocks, kThreads>>>(n, a.get(), b.get(), c.get());
  CUDA_CHECK_LAUNCH();
  Event t0, t1, t2;
  for (int k = 0; k < trials; ++k) {
    CUDA_CHECK(cudaMemsetAsync(sum.get(), 0, sizeof(double)));
    CUDA_CHECK(cudaEventRecord(t0.get()));
    triad_kernel<<<blocks, kThreads>>>(n, 3.0, a.get(), b.get(), c.get());
    CUDA_CHECK_LAUNCH();
    CUDA_CHECK(cudaEventRecord(t1.get()));
    read_kernel<<<blocks, kThreads>>>(n, a.get(), sum.get());
    CUDA_CHECK_LAUNCH();
    CUDA_CHECK(cudaEventRecord(t2.get()));
    out.triad_s.push_back(seconds_between(t0, t1));
    out.read_s.push_back(seconds_between(t1, t2));
  }
  CUDA_CHECK(cudaMemcpy(&out.sum, sum.get(), sizeof(double), cudaMemcpyDeviceToHost));
  std::vector<double> host(n);
  CUDA_CHECK(cudaMemcpy(host.data(), a.get(), n * sizeof(double), cudaMemcpyDeviceToHost));
  out.all_seven = true;
  for (double v : host) out.all_seven = out.all_seven && v == 7.0;
  return out;
}

}  // namespace hpcgi
