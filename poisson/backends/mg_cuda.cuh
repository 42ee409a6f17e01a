// The CUDA level kernels of mg.hpp for the cuda backend: one kernel per smoothing colour, the residual, the
// restriction and the prolongation, every launch checked. Each level is a whole padded (n+2)×(n+2) array (zero
// ghost rows and columns, the layout of gpu_base.cuh); level 0's x is the backend's z, its b the CG residual r,
// its residual the CG vector w.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "common/cuda_check.cuh"
#include "poisson/contract/stencil.hpp"
#include "poisson/methods/mg.hpp"

namespace poisson {

inline unsigned mg_blocks(long threads) { return static_cast<unsigned>((threads + 255) / 256); }

// One thread per point of one colour ((i + j) mod 2 == colour): x = (b + neighbours) / a, a = 4 plus e on the
// last row and on the last column.
template <class T>
__global__ void mg_smooth_kernel(long n, long s, int colour, T e, T* __restrict__ x, const T* __restrict__ b) {
  const long half = (n + 1) / 2;
  const long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x;
  if (k >= n * half) return;
  const long j = k / half, i = 2 * (k % half) + ((j + colour) & 1);
  if (i >= n) return;
  const long idx = (j + 1) * s + i + 1;
  const T a = 4 + (j == n - 1 ? e : T(0)) + (i == n - 1 ? e : T(0));
  x[idx] = plus_neighbours(b[idx], x[idx - 1], x[idx + 1], x[idx - s], x[idx + s]) / a;
}

template <class T>
__global__ void mg_residual_kernel(long n, long s, T e, const T* __restrict__ x, const T* __restrict__ b,
                                   T* __restrict__ r) {
  const long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x;
  if (k >= n * n) return;
  const long j = k / n, i = k % n, idx = (j + 1) * s + i + 1;
  const T a = 4 + (j == n - 1 ? e : T(0)) + (i == n - 1 ? e : T(0));
  r[idx] = b[idx] - five_point(a, x[idx], x[idx - 1], x[idx + 1], x[idx - s], x[idx + s]);
}

// One thread per coarse point: b_c = Pᵀ r; padded coarse (C, R) sits on padded fine (2C, 2R).
template <class T>
__global__ void mg_restrict_kernel(long nc, long sc, long s, const T* __restrict__ r, T* __restrict__ bc) {
  const long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x;
  if (k >= nc * nc) return;
  const long R = k / nc + 1, C = k % nc + 1, f = 2 * R * s + 2 * C;
  const T t0 = T(0.5) * r[f - s - 1] + r[f - 1] + T(0.5) * r[f + s - 1];
  const T t1 = T(0.5) * r[f - s] + r[f] + T(0.5) * r[f + s];
  const T t2 = T(0.5) * r[f - s + 1] + r[f + 1] + T(0.5) * r[f + s + 1];
  bc[R * sc + C] = T(0.5) * t0 + t1 + T(0.5) * t2;
}

// One thread per fine point: x += P x_c. Padded fine index K lies on padded coarse K/2 when even, between
// (K-1)/2 and (K+1)/2 when odd: the mean over {K>>1, (K+1)>>1} in both directions is the bilinear weight.
template <class T>
__global__ void mg_prolong_kernel(long n, long s, long sc, const T* __restrict__ xc, T* __restrict__ x) {
  const long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x;
  if (k >= n * n) return;
  const long R = k / n + 1, K = k % n + 1;
  const long ra = (R >> 1) * sc, rb = ((R + 1) >> 1) * sc, ca = K >> 1, cb = (K + 1) >> 1;
  x[R * s + K] += T(0.25) * (xc[ra + ca] + xc[ra + cb] + xc[rb + ca] + xc[rb + cb]);
}

template <class T>
class GpuMg final : public MgLevels {
 public:
  // Levels of mg_level_sizes(n); level 0 borrows z, r and w (padded (n+2)², device).
  GpuMg(long n, T* z, T* r, T* w) {
    const std::vector<long> sizes = mg_level_sizes(n);
    const std::vector<double> edge = mg_edge_terms(n);
    for (size_t l = 0; l < sizes.size(); ++l) {
      Level lv{sizes[l], sizes[l] + 2, static_cast<T>(edge[l]), z, r, w, nullptr};
      if (l > 0) {
        const long size = lv.s * lv.s;
        lv.own = std::make_unique<hpcgi::DeviceArray<T>>(3 * size);
        CUDA_CHECK(cudaMemset(lv.own->get(), 0, 3 * size * sizeof(T)));
        lv.x = lv.own->get(), lv.b = lv.x + size, lv.r = lv.x + 2 * size;
      }
      lv_.push_back(std::move(lv));
    }
  }
  // Bytes the coarse levels take (for the memory check before they are made).
  static double coarse_bytes(long n) { return sizeof(T) * mg_extra_values(n); }

  int levels() const override { return static_cast<int>(lv_.size()); }
  void zero(int l) override { CUDA_CHECK(cudaMemsetAsync(lv_[l].x, 0, lv_[l].s * lv_[l].s * sizeof(T))); }
  void smooth(int l, int colour) override {
    const Level& lv = lv_[l];
    mg_smooth_kernel<T><<<mg_blocks(lv.n * ((lv.n + 1) / 2)), 256>>>(lv.n, lv.s, colour, lv.e, lv.x, lv.b);
    CUDA_CHECK_LAUNCH();
  }
  void restrict_residual(int l) override {
    const Level &f = lv_[l], &c = lv_[l + 1];
    mg_residual_kernel<T><<<mg_blocks(f.n * f.n), 256>>>(f.n, f.s, f.e, f.x, f.b, f.r);
    CUDA_CHECK_LAUNCH();
    mg_restrict_kernel<T><<<mg_blocks(c.n * c.n), 256>>>(c.n, c.s, f.s, f.r, c.b);
    CUDA_CHECK_LAUNCH();
  }
  void prolong_add(int l) override {
    const Level &f = lv_[l], &c = lv_[l + 1];
    mg_prolong_kernel<T><<<mg_blocks(f.n * f.n), 256>>>(f.n, f.s, c.s, c.x, f.x);
    CUDA_CHECK_LAUNCH();
  }

 private:
  struct Level {
    long n, s;
    T e;  // added to the diagonal of the last row and column (mg.hpp)
    T *x, *b, *r;
    std::unique_ptr<hpcgi::DeviceArray<T>> own;
  };
  std::vector<Level> lv_;
};

}  // namespace poisson
