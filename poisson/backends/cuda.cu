// Our best CUDA backend, in both variants of kernels.hpp. Every dot is reduced once inside its kernel (warp
// shuffles, one double atomicAdd per block into a device scalar, accumulated in double also for float vectors),
// one small copy back per reduction, no other synchronisation.
//   classic:  three fused kernels (TeaLeaf's cg_calc_w, cg_calc_ur, cg_calc_p): [w = Ap, p·w] 2 vectors,
//             [x += αp, r -= αw, r·r] 6, [p = r + βp] 3: 11.
//   onesweep: one kernel per iteration (sweep_kernel): read r, p, x, write r, p, x: 6 vectors, plus the halo
//             rows and columns each tile recomputes.
//   --precond mg: classic with z = M⁻¹ r by the level kernels of mg_cuda.cuh, [r·z] and [p = z + βp].
//   --method fmg: the F-cycle of mg.hpp on the same level kernels, then V-cycles, [x += z], [r = b - Ax, r·r].
#include <memory>

#include "poisson/contract/backends.hpp"
#include "poisson/contract/stencil.hpp"
#include "poisson/backends/gpu_base.cuh"
#include "poisson/backends/mg_cuda.cuh"

namespace poisson {
namespace {

// Adds the block's sum of v to *out: warp shuffles, one slot of warp_sums per warp, warp 0 sums the slots. The
// block may be any whole number of warps up to kBlock threads (sweep_kernel runs kSweepThreads = 128, the others
// kBlock = 256): warp 0 reads blockDim.x / 32 slots, never a slot no warp of this block wrote. The closing barrier
// lets a kernel call it twice (sweep_kernel: r·r, then r·Ar): without it the other warps could write the second
// sum's partials into slots 1.. while warp 0 still reads the first's.
__device__ inline void block_sum_into(double v, double* out) {
  for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
  __shared__ double warp_sums[kBlock / 32];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5, warps = blockDim.x >> 5;
  if (lane == 0) warp_sums[warp] = v;
  __syncthreads();
  if (warp == 0) {
    v = lane < warps ? warp_sums[lane] : 0.0;
    for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
    if (lane == 0) atomicAdd(out, v);
  }
  __syncthreads();
}

// Grid-stride loops over the n×n interior points; idx is the padded index.
#define FOR_INTERIOR(n, s, k, idx)                                                                       \
  for (long k = blockIdx.x * static_cast<long>(blockDim.x) + threadIdx.x, idx = 0; k < (n) * (n) &&      \
       ((idx = (k / (n) + 1) * (s) + (k % (n)) + 1), true); k += static_cast<long>(gridDim.x) * blockDim.x)

// x += z on the interior points (fmg's correction).
template <class T>
__global__ void __launch_bounds__(kBlock) add_kernel(long n, long s, const T* __restrict__ z, T* __restrict__ x) {
  FOR_INTERIOR(n, s, k, idx) { x[idx] += z[idx]; }
}

// r = b - A x and r·r, accumulated in double into *rr (fmg's true residual of the new x).
template <class T>
__global__ void __launch_bounds__(kBlock) residual_kernel(long n, long s, const T* __restrict__ x,
                                                          const T* __restrict__ b, T* __restrict__ r, double* rr) {
  double acc = 0;
  FOR_INTERIOR(n, s, k, idx) {
    const T v = b[idx] - five_point_at(x, s, idx);
    r[idx] = v;
    acc += static_cast<double>(v) * v;
  }
  block_sum_into(acc, rr);
}

template <class T>
__global__ void __launch_bounds__(kBlock) calc_w_kernel(long n, long s, const T* __restrict__ p, T* __restrict__ w,
                                                        double* pw) {
  double acc = 0;
  FOR_INTERIOR(n, s, k, idx) {
    const T pc = p[idx];
    const T v = five_point(T(4), pc, p[idx - 1], p[idx + 1], p[idx - s], p[idx + s]);
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
__global__ void __launch_bounds__(kBlock) dot_kernel(long n, long s, const T* __restrict__ a, const T* __restrict__ b,
                                                     double* out) {
  double acc = 0;
  FOR_INTERIOR(n, s, k, idx) { acc += static_cast<double>(a[idx]) * b[idx]; }
  block_sum_into(acc, out);
}

// The one-sweep iteration (kernels.hpp): p = r + βp, x += αp, r -= α Ap, with r·r and r·Ar of the new r. Blocks
// run in any order, so r and p are read from one buffer and written to another (x only at a block's own points,
// in place). A block updates kSweepCols columns and kSweepRows rows, one thread per column of the tile plus two
// halo columns each side, marching down its rows like the CPU sweep: at row y every thread makes p_k[y] (into a
// shared ring of three rows), then r_{k+1}[y-1] from the ring (into a second ring), then the r·Ar term of row y-2.
// The halo (two rows and columns each side) is recomputed from the old r and p, never exchanged.
constexpr int kSweepThreads = 128;
constexpr int kSweepCols = kSweepThreads - 4;
constexpr int kSweepRows = 32;
static_assert(kSweepThreads % 32 == 0 && kSweepThreads <= kBlock, "block_sum_into needs whole warps, <= kBlock");

template <class T>
__global__ void __launch_bounds__(kSweepThreads)
    sweep_kernel(long n, long s, T alpha, T beta, const T* __restrict__ r_old, const T* __restrict__ p_old,
                 T* __restrict__ r_new, T* __restrict__ p_new, T* __restrict__ x, double* dots) {
  __shared__ T ring_p[3][kSweepThreads];  // row y in slot (y + 3) % 3
  __shared__ T ring_r[3][kSweepThreads];
  const int t = threadIdx.x;
  const long c = static_cast<long>(blockIdx.x) * kSweepCols - 2 + t;  // grid column 0..n-1 (padded c + 1)
  const long y0 = static_cast<long>(blockIdx.y) * kSweepRows;
  const long y1 = min(y0 + kSweepRows, n);
  const bool col_in = c >= 0 && c < n;
  const bool own_col = col_in && t >= 2 && t < kSweepThreads - 2;
  const bool mid_col = col_in && t >= 1 && t < kSweepThreads - 1;  // has both neighbours in the ring
  double rr = 0, rar = 0;
  T r_above = 0;  // old r of row y - 1 in this column, read at the previous step
  for (long y = y0 - 2; y <= y1 + 1; ++y) {
    const long idx = (y + 1) * s + c + 1;
    T ro = 0, pk = 0;
    if (col_in && y >= 0 && y < n) {
      ro = r_old[idx];
      pk = ro + beta * p_old[idx];
      if (own_col && y >= y0 && y < y1) {
        p_new[idx] = pk;
        x[idx] += alpha * pk;
      }
    }
    ring_p[(y + 3) % 3][t] = pk;
    __syncthreads();
    const long q = y - 1;
    if (q >= y0 - 1) {
      T rn = 0;
      if (mid_col && q >= 0 && q < n) {
        const T* pc = ring_p[(q + 3) % 3];
        const T ap = five_point_rows(pc, ring_p[(q + 2) % 3], ring_p[(q + 4) % 3], t);
        rn = r_above - alpha * ap;
        if (own_col && q >= y0 && q < y1) {
          r_new[idx - s] = rn;
          rr += static_cast<double>(rn) * rn;
        }
      }
      ring_r[(q + 3) % 3][t] = rn;
    }
    r_above = ro;
    __syncthreads();
    const long z = y - 2;
    if (own_col && z >= y0 && z < y1) {
      const T* rc = ring_r[(z + 3) % 3];
      const T u = rc[t];
      rar += static_cast<double>(u) *
             five_point_rows(rc, ring_r[(z + 2) % 3], ring_r[(z + 4) % 3], t);
    }
  }
  block_sum_into(rr, dots);
  block_sum_into(rar, dots + 1);
}

template <class T>
class Cuda final : public GpuBase<T, OneSweepKernels<T>>, public Preconditioned {
  using B = GpuBase<T, OneSweepKernels<T>>;

 public:
  explicit Cuda(const Config& cfg)
      : B(cfg, "cuda"), onesweep_(cfg.variant == Variant::onesweep), fmg_(cfg.method == Method::fmg), sum_(2), host_sum_(2) {
    int dev = 0, sms = 0;
    CUDA_CHECK(cudaGetDevice(&dev));
    CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
    const long pts = B::n_ * B::n_;
    blocks_ = static_cast<unsigned>(std::min<long>((pts + kBlock - 1) / kBlock, 8L * sms));
    if (onesweep_) {
      // The second buffer of p (w, which onesweep does not use, is the second buffer of r).
      hpcgi::require_device_memory("backend cuda --variant onesweep at N = " + std::to_string(B::n_),
                                   static_cast<double>(B::size_) * sizeof(T));
      p_spare_ = std::make_unique<hpcgi::DeviceArray<T>>(B::size_);
      CUDA_CHECK(cudaMemset(p_spare_->get(), 0, B::size_ * sizeof(T)));
    }
    if (cfg.multigrid()) {
      hpcgi::require_device_memory("backend cuda --precond mg at N = " + std::to_string(B::n_),
                                   static_cast<double>(B::size_) * sizeof(T) + GpuMg<T>::coarse_bytes(B::n_));
      z_ = std::make_unique<hpcgi::DeviceArray<T>>(B::size_);
      CUDA_CHECK(cudaMemset(z_->get(), 0, B::size_ * sizeof(T)));
      mg_ = std::make_unique<GpuMg<T>>(B::n_, z_->get(), B::r_.get(), B::w_.get());
    }
  }

  double precondition() override {
    vcycle(*mg_);
    zero();
    dot_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, B::r_.get(), z_->get(), sum_.get());
    CUDA_CHECK_LAUNCH();
    return fetch(1)[0];
  }
  // The cycles on the correction z of the residual equation A z = r from z = 0 (kernels.hpp), then correct().
  double solve_cycle(bool full) override {
    full ? fmg(*mg_) : vcycle_solve(*mg_, 0, true);
    return correct();
  }
  // x += z; r = b - A x recomputed from the new x (serial's correct(): the stopping test reads the true residual),
  // and r·r.
  double correct() {
    add_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, z_->get(), B::x_.get());
    CUDA_CHECK_LAUNCH();
    zero();
    residual_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, B::x_.get(), B::b_.get(), B::r_.get(), sum_.get());
    CUDA_CHECK_LAUNCH();
    return fetch(1)[0];
  }
  void calc_p_z(double beta) override {
    calc_p_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, static_cast<T>(beta), z_->get(), B::p_.get());
    CUDA_CHECK_LAUNCH();
  }
  std::vector<long> mg_sizes() const override { return mg_level_sizes(B::n_); }
  std::vector<double> fmg_vectors_per_level() const override {
    return poisson::fmg_vectors_per_level(B::n_, kSeparateLevelKernels);
  }
  double fmg_correction_vectors() const override { return kFmgCorrectionVectors; }
  OneSweepKernels<T>* one_sweep() override { return this; }
  Preconditioned* multigrid() override { return this; }
  double apply_dot(const GridFn& x, const GridFn& y) override {
    std::vector<T> h(B::size_, T(0));
    for (long j = 0; j < B::n_; ++j)
      for (long i = 0; i < B::n_; ++i) h[(j + 1) * B::s_ + i + 1] = static_cast<T>(x(i, j));
    CUDA_CHECK(cudaMemcpy(B::r_.get(), h.data(), B::size_ * sizeof(T), cudaMemcpyHostToDevice));
    vcycle(*mg_);
    CUDA_CHECK(cudaMemcpy(h.data(), z_->get(), B::size_ * sizeof(T), cudaMemcpyDeviceToHost));
    double sum = 0;
    for (long j = 0; j < B::n_; ++j)
      for (long i = 0; i < B::n_; ++i) sum += static_cast<double>(h[(j + 1) * B::s_ + i + 1]) * y(i, j);
    return sum;
  }

  double init() override {
    const double rr = B::init_vectors();
    cur_r_ = B::r_.get();
    cur_p_ = B::p_.get();
    next_r_ = B::w_.get();
    if (p_spare_) next_p_ = p_spare_->get();
    return rr;
  }

  double calc_w() override {
    zero();
    calc_w_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, B::p_.get(), B::w_.get(), sum_.get());
    CUDA_CHECK_LAUNCH();
    return fetch(1)[0];
  }
  double calc_ur(double alpha) override {
    zero();
    calc_ur_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, static_cast<T>(alpha), B::p_.get(), B::w_.get(),
                                           B::x_.get(), B::r_.get(), sum_.get());
    CUDA_CHECK_LAUNCH();
    return fetch(1)[0];
  }
  void calc_p(double beta) override {
    calc_p_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, static_cast<T>(beta), B::r_.get(), B::p_.get());
    CUDA_CHECK_LAUNCH();
  }

  // δ_0 = r·Ar by the classic stencil kernel; its w = Ar lands in the next r buffer, which the first sweep
  // overwrites everywhere inside the grid.
  double r_Ar() override {
    zero();
    calc_w_kernel<T><<<blocks_, kBlock>>>(B::n_, B::s_, cur_r_, next_r_, sum_.get());
    CUDA_CHECK_LAUNCH();
    return fetch(1)[0];
  }
  SweepDots sweep(double alpha, double beta) override {
    zero();
    const dim3 grid(static_cast<unsigned>((B::n_ + kSweepCols - 1) / kSweepCols),
                    static_cast<unsigned>((B::n_ + kSweepRows - 1) / kSweepRows));
    sweep_kernel<T><<<grid, kSweepThreads>>>(B::n_, B::s_, static_cast<T>(alpha), static_cast<T>(beta), cur_r_,
                                             cur_p_, next_r_, next_p_, B::x_.get(), sum_.get());
    CUDA_CHECK_LAUNCH();
    std::swap(cur_r_, next_r_);
    std::swap(cur_p_, next_p_);
    const double* d = fetch(2);
    return {d[0], d[1]};
  }

  int vectors_per_iteration() const override {
    return mg_ ? (fmg_ ? kFmgCorrectionVectors : 11 + 2) + mg_vectors_per_cycle(B::n_)
               : onesweep_ ? kVectorsOneSweep : kVectorsClassic;
  }
  std::map<std::string, std::string> info() const override {
    auto i = B::info();
    i["dot"] = "fused, double accumulation";
    return i;
  }

 private:
  void zero() { CUDA_CHECK(cudaMemsetAsync(sum_.get(), 0, 2 * sizeof(double))); }
  const double* fetch(int count) {
    CUDA_CHECK(cudaMemcpyAsync(host_sum_.get(), sum_.get(), count * sizeof(double), cudaMemcpyDeviceToHost));
    CUDA_CHECK(cudaStreamSynchronize(0));
    return host_sum_.get();
  }
  bool onesweep_, fmg_;
  hpcgi::DeviceArray<double> sum_;
  hpcgi::PinnedArray<double> host_sum_;  // an owner: freed when p_spare_'s allocation below it throws
  unsigned blocks_ = 1;
  std::unique_ptr<hpcgi::DeviceArray<T>> p_spare_;
  std::unique_ptr<hpcgi::DeviceArray<T>> z_;  // --precond mg: z = M⁻¹ r, and the hierarchy
  std::unique_ptr<GpuMg<T>> mg_;
  // onesweep: the current and next buffers of r and p, swapped after every sweep.
  T *cur_r_ = nullptr, *cur_p_ = nullptr, *next_r_ = nullptr, *next_p_ = nullptr;
};

}  // namespace

POISSON_BACKEND_FACTORY(make_cuda, Cuda)

}  // namespace poisson
