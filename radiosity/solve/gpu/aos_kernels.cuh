// The AOS kernels on the GPU, own code without cuBLAS (report §3.8.1: cuBLAS takes arrays of floats, not
// {r, g, b} records): backend cuda runs them on all rows, backend hybrid on the GPU's first rows.
//
// The product reads F once for all three channels: a block of 8 warps takes 16 rows, each warp two of them; the
// 32 lanes read consecutive F_ij of both rows (coalesced) and keep three sums per row, one per channel; x is staged
// through shared memory a tile of patches at a time, so each x_j, read once per block, serves 16 rows, and a
// lane's x_j are 3 words apart (no bank conflicts); the lanes' sums meet by warp shuffles. Sums are kept in T, as
// on the CPU. Reductions (dot, dist2) add in double, first per block, then the block sums in a fixed order in a
// second kernel: the same bits on every run.
#pragma once
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "radiosity/solve/gpu/device_common.cuh"
#include "radiosity/solve/core/system.hpp"

namespace radiosity::gpu {

inline constexpr int kRowsPerWarp = 2;
inline constexpr int kRowsPerBlock = kBlock / 32 * kRowsPerWarp;
inline constexpr int kTile = 256;              // patches of x in shared memory at a time
inline constexpr size_t kReduceBlocks = 1024;  // the most partial sums a reduction leaves

// Two rows' three sums += F values f0, f1 (one per lane) times the lane's x_j, staged at u[0..2].
template <class T>
__device__ __forceinline__ void accumulate(T f0, T f1, const T* u, T& a0, T& a1, T& a2, T& b0, T& b1, T& b2) {
  a0 += f0 * u[0];
  a1 += f0 * u[1];
  a2 += f0 * u[2];
  b0 += f1 * u[0];
  b1 += f1 * u[1];
  b2 += f1 * u[2];
}

// Rows [0, rows) of y = a·x + c·ρ ⊙ (F x) + d·e; F holds those rows (rows × n), the vectors all n patches.
template <class T>
__global__ void __launch_bounds__(kBlock)
    aos_matvec_kernel(size_t n, size_t rows, const float* __restrict__ F, const T* __restrict__ x, T* __restrict__ y,
                      const T* __restrict__ rho, const T* __restrict__ e, T a, T c, T d) {
  constexpr int kSteps = kTile / 32;  // F values per lane and row in a tile
  __shared__ T xs[3 * kTile];
  const int lane = threadIdx.x & 31;
  const size_t i0 = blockIdx.x * size_t(kRowsPerBlock) + (threadIdx.x >> 5) * size_t(kRowsPerWarp);
  const bool has0 = i0 < rows, has1 = i0 + 1 < rows;  // the same for the whole warp
  const float* __restrict__ F0 = F + (has0 ? i0 : 0) * n + lane;
  const float* __restrict__ F1 = F + (has1 ? i0 + 1 : 0) * n + lane;
  T a0 = 0, a1 = 0, a2 = 0, b0 = 0, b1 = 0, b2 = 0;
  for (size_t j0 = 0; j0 < n; j0 += kTile) {
    const int m = n - j0 < size_t(kTile) ? static_cast<int>(n - j0) : kTile;  // patches in this tile
    __syncthreads();  // no warp still reads the previous tile
    for (int k = threadIdx.x; k < 3 * kTile; k += kBlock) xs[k] = k < 3 * m ? x[3 * j0 + k] : T(0);
    __syncthreads();
    if (!has0) continue;
    float f0[kSteps], f1[kSteps];
    if (m == kTile && has1) {
      // A whole tile of two rows: all loads first, unconditional, so that they are in flight together. F is
      // read once: streaming loads (__ldcs) leave the cache to x.
#pragma unroll
      for (int s = 0; s < kSteps; ++s) {
        f0[s] = __ldcs(F0 + j0 + 32 * s);
        f1[s] = __ldcs(F1 + j0 + 32 * s);
      }
    } else {  // the last tile of a row, or the last row of an odd count
#pragma unroll
      for (int s = 0; s < kSteps; ++s) {
        const bool in = 32 * s + lane < m;
        f0[s] = in ? __ldcs(F0 + j0 + 32 * s) : 0.f;
        f1[s] = in && has1 ? __ldcs(F1 + j0 + 32 * s) : 0.f;
      }
    }
#pragma unroll
    for (int s = 0; s < kSteps; ++s)
      accumulate<T>(f0[s], f1[s], xs + 3 * (32 * s + lane), a0, a1, a2, b0, b1, b2);
  }
  for (int o = 16; o > 0; o >>= 1) {
    a0 += __shfl_down_sync(0xffffffffu, a0, o);
    a1 += __shfl_down_sync(0xffffffffu, a1, o);
    a2 += __shfl_down_sync(0xffffffffu, a2, o);
    b0 += __shfl_down_sync(0xffffffffu, b0, o);
    b1 += __shfl_down_sync(0xffffffffu, b1, o);
    b2 += __shfl_down_sync(0xffffffffu, b2, o);
  }
  if (lane != 0) return;
  const T sa[3] = {a0, a1, a2}, sb[3] = {b0, b1, b2};
  for (int ch = 0; ch < 3; ++ch) {
    if (has0) y[3 * i0 + ch] = a * x[3 * i0 + ch] + c * rho[3 * i0 + ch] * sa[ch] + d * e[3 * i0 + ch];
    if (has1) y[3 * i0 + 3 + ch] = a * x[3 * i0 + 3 + ch] + c * rho[3 * i0 + 3 + ch] * sb[ch] + d * e[3 * i0 + 3 + ch];
  }
}

// Thread 0 of the block gets the block's sums of v0, v1, v2 (warp shuffles, then the warps' sums in order).
__device__ inline void block_sum3(double& v0, double& v1, double& v2) {
  __shared__ double warp_sums[3][kBlock / 32];
  for (int o = 16; o > 0; o >>= 1) {
    v0 += __shfl_down_sync(0xffffffffu, v0, o);
    v1 += __shfl_down_sync(0xffffffffu, v1, o);
    v2 += __shfl_down_sync(0xffffffffu, v2, o);
  }
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  if (lane == 0) {
    warp_sums[0][warp] = v0;
    warp_sums[1][warp] = v1;
    warp_sums[2][warp] = v2;
  }
  __syncthreads();
  if (threadIdx.x == 0) {
    v0 = v1 = v2 = 0;
    for (int w = 0; w < kBlock / 32; ++w) {
      v0 += warp_sums[0][w];
      v1 += warp_sums[1][w];
      v2 += warp_sums[2][w];
    }
  }
}

// Block sums of Σ x·y (Diff false) or Σ (x - y)² (Diff true) per channel over patches [0, rows), into
// partial[3 b + c].
template <class T, bool Diff>
__global__ void __launch_bounds__(kBlock)
    aos_reduce_kernel(size_t rows, const T* __restrict__ x, const T* __restrict__ y, double* __restrict__ partial) {
  double s0 = 0, s1 = 0, s2 = 0;
  for (size_t i = blockIdx.x * size_t(kBlock) + threadIdx.x; i < rows; i += size_t(gridDim.x) * kBlock) {
    const double x0 = x[3 * i], x1 = x[3 * i + 1], x2 = x[3 * i + 2];
    const double y0 = y[3 * i], y1 = y[3 * i + 1], y2 = y[3 * i + 2];
    if (Diff) {
      s0 += (x0 - y0) * (x0 - y0);
      s1 += (x1 - y1) * (x1 - y1);
      s2 += (x2 - y2) * (x2 - y2);
    } else {
      s0 += x0 * y0;
      s1 += x1 * y1;
      s2 += x2 * y2;
    }
  }
  block_sum3(s0, s1, s2);
  if (threadIdx.x == 0) {
    partial[3 * blockIdx.x] = s0;
    partial[3 * blockIdx.x + 1] = s1;
    partial[3 * blockIdx.x + 2] = s2;
  }
}

// out[c] = Σ_b partial[3 b + c] over `blocks` block sums; one block. Static: every .cu that includes this header
// has its own copy (a template kernel, as the others, the linker merges).
static __global__ void __launch_bounds__(kBlock) sum_partials_kernel(unsigned blocks, const double* __restrict__ partial,
                                                              double* __restrict__ out) {
  double s0 = 0, s1 = 0, s2 = 0;
  for (unsigned b = threadIdx.x; b < blocks; b += kBlock) {
    s0 += partial[3 * b];
    s1 += partial[3 * b + 1];
    s2 += partial[3 * b + 2];
  }
  block_sum3(s0, s1, s2);
  if (threadIdx.x == 0) {
    out[0] = s0;
    out[1] = s1;
    out[2] = s2;
  }
}

// y = a ⊙ x + b ⊙ y over the 3·rows values of patches [0, rows).
template <class T>
__global__ void __launch_bounds__(kBlock) aos_axpby_kernel(size_t values, T a0, T a1, T a2, const T* x, T b0,
                                                           T b1, T b2, T* y) {  // x may be y
  for (size_t k = blockIdx.x * size_t(kBlock) + threadIdx.x; k < values; k += size_t(gridDim.x) * kBlock) {
    const int c = static_cast<int>(k % 3);
    const T a = c == 0 ? a0 : c == 1 ? a1 : a2;
    const T b = c == 0 ? b0 : c == 1 ? b1 : b2;
    y[k] = a * x[k] + b * y[k];
  }
}

// The vectors (slots) of all n patches as {r, g, b} records on the device, and F's first `rows` rows (none when the
// system's F is stored otherwise: backend cuda's sparse_device.cuh has it); every operation works on patches
// [0, rows). Work goes to the stream in order; only a reduction's result waits.
template <class T>
class AosDevice {
 public:
  // Device memory the constructor will allocate (dense: with F's rows).
  static double bytes_needed(size_t n, size_t rows, int vectors, bool dense = true) {
    return (dense ? 4.0 * double(rows) * double(n) : 0.0) + double(vectors + 2) * 3.0 * double(n) * sizeof(T) +
           (3.0 * kReduceBlocks + 3) * sizeof(double);
  }

  AosDevice(const System& sys, size_t rows, int vectors, cudaStream_t s, DeviceClock& clock)
      : n_(sys.n), rows_(rows), s_(s), clock_(clock), F_(std::max<size_t>(1, dense_float32(sys) ? rows * sys.n : 0)),  // never 0 bytes
        rho_(3 * sys.n), e_(3 * sys.n),
        partial_(3 * kReduceBlocks), sum_(3), host_sum_(3) {
    clock_.timed(DeviceClock::kUpload, [&] {
      if (rows_ > 0 && dense_float32(sys))
        CUDA_CHECK(cudaMemcpyAsync(F_.get(), dense_float32(sys), rows_ * n_ * sizeof(float), cudaMemcpyHostToDevice, s_));
    });
    put(rho_.get(), sys.reflectivity);
    put(e_.get(), sys.emission);
    for (int v = 0; v < vectors; ++v) {
      vec_.push_back(std::make_unique<hpcgi::DeviceArray<T>>(3 * n_));
      CUDA_CHECK(cudaMemsetAsync(vec_.back()->get(), 0, 3 * n_ * sizeof(T), s_));
    }
  }

  size_t rows() const { return rows_; }
  T* vec(int v) { return vec_.at(v)->get(); }
  const T* rho() const { return rho_.get(); }
  const T* e() const { return e_.get(); }

  void upload(int v, const std::vector<Rgb>& x) { put(vec(v), x); }
  // Patches [0, count) of slot v into x[0, count).
  void download(int v, std::vector<Rgb>& x, size_t count) {
    std::vector<T> h(3 * count);
    if (count > 0) CUDA_CHECK(cudaMemcpyAsync(h.data(), vec(v), h.size() * sizeof(T), cudaMemcpyDeviceToHost, s_));
    CUDA_CHECK(cudaStreamSynchronize(s_));
    for (size_t i = 0; i < count; ++i)
      for (int c = 0; c < 3; ++c) x[i][c] = h[3 * i + c];
  }

  void matvec(int y, int x, T a, T c, T d) {
    if (rows_ == 0) return;
    const unsigned blocks = static_cast<unsigned>((rows_ + kRowsPerBlock - 1) / kRowsPerBlock);
    clock_.timed(DeviceClock::kCompute, [&] {
      aos_matvec_kernel<T><<<blocks, kBlock, 0, s_>>>(n_, rows_, F_.get(), vec(x), vec(y), rho_.get(), e_.get(),
                                                       a, c, d);
      CUDA_CHECK_LAUNCH();
    });
  }

  // A reduction in two halves, so that the hybrid backend's CPU adds its rows while the GPU adds its own:
  // reduce_start enqueues the kernels and the copy of the three sums; reduce_result waits for them.
  void reduce_start(bool diff, int x, int y) {
    if (rows_ == 0) return;
    const unsigned blocks = grid_for(rows_, kReduceBlocks);
    clock_.timed(DeviceClock::kCompute, [&] {
      if (diff)
        aos_reduce_kernel<T, true><<<blocks, kBlock, 0, s_>>>(rows_, vec(x), vec(y), partial_.get());
      else
        aos_reduce_kernel<T, false><<<blocks, kBlock, 0, s_>>>(rows_, vec(x), vec(y), partial_.get());
      CUDA_CHECK_LAUNCH();
      sum_partials_kernel<<<1, kBlock, 0, s_>>>(blocks, partial_.get(), sum_.get());
      CUDA_CHECK_LAUNCH();
    });
    clock_.timed(DeviceClock::kTransfer, [&] {
      CUDA_CHECK(cudaMemcpyAsync(host_sum_.get(), sum_.get(), 3 * sizeof(double), cudaMemcpyDeviceToHost, s_));
    });
    clock_.moved(3 * sizeof(double));
  }
  Rgb reduce_result() {
    if (rows_ == 0) return {0, 0, 0};
    CUDA_CHECK(cudaStreamSynchronize(s_));
    const double* h = host_sum_.get();
    return {h[0], h[1], h[2]};
  }

  void axpby(int y, const Rgb& a, int x, const Rgb& b) {
    if (rows_ == 0) return;
    clock_.timed(DeviceClock::kCompute, [&] {
      aos_axpby_kernel<T><<<grid_for(3 * rows_, 4096), kBlock, 0, s_>>>(3 * rows_, T(a[0]), T(a[1]), T(a[2]), vec(x),
                                                                        T(b[0]), T(b[1]), T(b[2]), vec(y));
      CUDA_CHECK_LAUNCH();
    });
  }
  void copy(int y, int x) {
    if (rows_ == 0) return;
    clock_.timed(DeviceClock::kCompute, [&] {
      CUDA_CHECK(cudaMemcpyAsync(vec(y), vec(x), 3 * rows_ * sizeof(T), cudaMemcpyDeviceToDevice, s_));
    });
  }

 private:
  // All n patches of a host vector into a device vector, converted to T; waits, so the staging vector may go.
  void put(T* dst, const std::vector<Rgb>& src) {
    std::vector<T> h(3 * n_);
    for (size_t i = 0; i < n_; ++i)
      for (int c = 0; c < 3; ++c) h[3 * i + c] = T(src[i][c]);
    CUDA_CHECK(cudaMemcpyAsync(dst, h.data(), h.size() * sizeof(T), cudaMemcpyHostToDevice, s_));
    CUDA_CHECK(cudaStreamSynchronize(s_));
  }

  size_t n_, rows_;
  cudaStream_t s_;
  DeviceClock& clock_;
  hpcgi::DeviceArray<float> F_;
  hpcgi::DeviceArray<T> rho_, e_;
  hpcgi::DeviceArray<double> partial_, sum_;
  PinnedArray<double> host_sum_;
  std::vector<std::unique_ptr<hpcgi::DeviceArray<T>>> vec_;
};

}  // namespace radiosity::gpu
