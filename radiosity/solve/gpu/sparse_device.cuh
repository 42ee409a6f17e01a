// The product y = a·x + c·ρ ⊙ (F x) + d·e of a csr or compressed F (ff_matrix.hpp) on the GPU, for backends cuda
// (AOS records) and cublas (SOA channels). Channel ch of patch i is at ch·cs + i·ps in every vector: AOS cs = 1,
// ps = 3; SOA cs = the channel stride, ps = 1.
//   csr float32 values, float working precision: cuSPARSE (the library the field uses), one cusparseSpMM of F
//     with x as a dense n × 3 right-hand side (AOS: row-major, ld 3; SOA: column-major, ld the stride), so F is
//     read once for the three channels, into a scratch vector; then the affine terms by a kernel.
//   everything else (compressed, 16-bit values, double working precision, which cuSPARSE does not mix with float
//     values): one fused kernel of ours, a warp per row: the 32 lanes read 32 consecutive entries (coalesced
//     values and columns or steps), a compressed row's columns are the steps' running sum (a warp prefix sum per
//     32 entries, carried over), each lane gathers its x_j's three channels and keeps three sums, which meet by
//     warp shuffles; lane 0 writes the row's affine result. Values are widened to T as they are read.
// The sums run in another order than the CPU's (csr_kernels.hpp): results agree to rounding, not bits.
#pragma once
#include <climits>
#include <cstdint>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <cuda_fp16.h>

#include "radiosity/solve/gpu/device_common.cuh"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity::gpu {

inline constexpr int kWarpsPerBlock = kBlock / 32;

__device__ __forceinline__ float widen(float f) { return f; }
struct Half16 {
  uint16_t bits;
};
struct BFloat16 {
  uint16_t bits;
};
__device__ __forceinline__ float widen(Half16 h) { return __half2float(__ushort_as_half(h.bits)); }
__device__ __forceinline__ float widen(BFloat16 b) { return __uint_as_float(uint32_t(b.bits) << 16); }

// Rows [0, rows) of y; Steps: columns from compressed's uint16 steps, else csr's int32 columns.
template <class T, class Val, bool Steps>
__global__ void __launch_bounds__(kBlock)
    sparse_rows_kernel(size_t rows, const int64_t* __restrict__ start, const Val* __restrict__ F,
                       const int32_t* __restrict__ col, const uint16_t* __restrict__ step, const T* __restrict__ x,
                       T* __restrict__ y, const T* __restrict__ rho, const T* __restrict__ e, T a, T c, T d,
                       size_t cs, size_t ps) {
  const int lane = threadIdx.x & 31;
  const size_t i = blockIdx.x * size_t(kWarpsPerBlock) + (threadIdx.x >> 5);
  if (i >= rows) return;  // the whole warp
  const int64_t k0 = start[i], k1 = start[i + 1];
  T s0 = 0, s1 = 0, s2 = 0;
  int64_t before = -1;  // compressed: the column of the entry before this chunk
  for (int64_t kk = k0; kk < k1; kk += 32) {
    const int64_t k = kk + lane;
    const bool in = k < k1;
    const T f = in ? T(widen(F[k])) : T(0);
    int64_t j;
    if constexpr (Steps) {
      int64_t run = in ? int64_t(step[k]) : 0;  // inclusive prefix sum of the chunk's steps
      for (int o = 1; o < 32; o <<= 1) {
        const int64_t up = __shfl_up_sync(0xffffffffu, run, o);
        if (lane >= o) run += up;
      }
      j = before + run;
      before += __shfl_sync(0xffffffffu, run, 31);
    } else {
      j = in ? int64_t(col[k]) : 0;
    }
    if (in) {
      const size_t p = size_t(j) * ps;
      s0 += f * x[p];
      s1 += f * x[p + cs];
      s2 += f * x[p + 2 * cs];
    }
  }
  for (int o = 16; o > 0; o >>= 1) {
    s0 += __shfl_down_sync(0xffffffffu, s0, o);
    s1 += __shfl_down_sync(0xffffffffu, s1, o);
    s2 += __shfl_down_sync(0xffffffffu, s2, o);
  }
  if (lane != 0) return;
  const T s[3] = {s0, s1, s2};
  for (int ch = 0; ch < 3; ++ch) {
    const size_t q = i * ps + ch * cs;
    y[q] = a * x[q] + c * rho[q] * s[ch] + d * e[q];
  }
}

// y = a·x + c·ρ ⊙ p + d·e over patches [0, n), p = F x from cuSPARSE in the vectors' layout.
template <class T>
__global__ void __launch_bounds__(kBlock)
    sparse_affine_kernel(size_t n, size_t cs, size_t ps, const T* __restrict__ x, const T* __restrict__ p,
                         const T* __restrict__ rho, const T* __restrict__ e, T* __restrict__ y, T a, T c, T d) {
  for (size_t i = blockIdx.x * size_t(kBlock) + threadIdx.x; i < n; i += size_t(gridDim.x) * kBlock)
    for (int ch = 0; ch < 3; ++ch) {
      const size_t q = i * ps + ch * cs;
      y[q] = a * x[q] + c * rho[q] * p[q] + d * e[q];
    }
}

// F in csr or compressed on the device, and its product.
template <class T>
class SparseDevice {
 public:
  // Whether cuSPARSE runs the product: csr float32 in float, its row starts and sizes within int32.
  static bool by_cusparse(const FFMatrixView& F) {
    return std::is_same_v<T, float> && F.storage == FFStorage::csr && F.values == FFValues::float32 &&
           F.row_start[F.n] <= INT_MAX && F.n <= size_t(INT_MAX);
  }
  static double entries(const FFMatrixView& F) { return double(F.row_start[F.n]); }
  // The bytes one product reads from F: the entries (value and column or step) and the row starts (int32 for
  // cuSPARSE, int64 for ours).
  static double matrix_bytes(const FFMatrixView& F) {
    const double per = double(value_bytes(F.values)) + (F.storage == FFStorage::csr ? 4.0 : 2.0);
    return entries(F) * per + (by_cusparse(F) ? 4.0 : 8.0) * double(F.n + 1);
  }
  // Device memory the constructor allocates: F, and for cuSPARSE its scratch product (vec_values of T) and
  // workspace (not known before the handle exists: kSparseWorkspace is kept free for it).
  static double bytes_needed(const FFMatrixView& F, size_t vec_values) {
    return matrix_bytes(F) + (by_cusparse(F) ? double(vec_values) * sizeof(T) + kSparseWorkspace : 0.0);
  }

  // cs, ps: the vectors' layout (above); vec_values: the values of one vector (the scratch product's size).
  SparseDevice(const FFMatrixView& F, size_t cs, size_t ps, size_t vec_values, cudaStream_t s, DeviceClock& clock)
      : n_(F.n), cs_(cs), ps_(ps), scale_(F.scale), storage_(F.storage), values_(F.values), cusparse_(by_cusparse(F)),
        s_(s), clock_(clock), data_(std::max<size_t>(1, size_t(entries(F)) * value_bytes(F.values))),
        index_(std::max<size_t>(1, size_t(entries(F)) * (F.storage == FFStorage::csr ? 4 : 2))),
        start_(std::max<size_t>(1, (n_ + 1) * (cusparse_ ? 4 : 8))), p_(cusparse_ ? vec_values : 1) {
    const size_t m = size_t(entries(F));
    clock_.timed(DeviceClock::kUpload, [&] {
      copy_up(data_.get(), F.data, m * value_bytes(F.values));
      if (F.storage == FFStorage::csr)
        copy_up(index_.get(), F.col, m * sizeof(int32_t));
      else
        copy_up(index_.get(), F.step, m * sizeof(uint16_t));
      if (cusparse_) {
        std::vector<int32_t> start32(F.row_start, F.row_start + n_ + 1);
        copy_up(start_.get(), start32.data(), start32.size() * sizeof(int32_t));
        CUDA_CHECK(cudaStreamSynchronize(s_));  // before start32 goes
      } else {
        copy_up(start_.get(), F.row_start, (n_ + 1) * sizeof(int64_t));
      }
    });
    if (cusparse_) describe(m);
  }
  SparseDevice(const SparseDevice&) = delete;
  SparseDevice& operator=(const SparseDevice&) = delete;

  // y = a·x + c·ρ ⊙ (F x) + d·e over all n patches (the float16 scale folded into c). y != x.
  void matvec(const T* x, T* y, const T* rho, const T* e, T a, T c, T d) {
    const T cs = T(double(c) * scale_);
    clock_.timed(DeviceClock::kCompute, [&] {
      if (cusparse_) {
        const float one = 1, zero = 0;
        CUSPARSE_CHECK(cusparseDnMatSetValues(d_.X, const_cast<T*>(x)));
        CUSPARSE_CHECK(cusparseSpMM(handle_->get(), CUSPARSE_OPERATION_NON_TRANSPOSE,
                                    CUSPARSE_OPERATION_NON_TRANSPOSE, &one, d_.A, d_.X, &zero, d_.P, CUDA_R_32F,
                                    CUSPARSE_SPMM_ALG_DEFAULT, work_ ? work_->get() : nullptr));
        sparse_affine_kernel<T><<<grid_for(n_, 1024), kBlock, 0, s_>>>(n_, cs_, ps_, x, p_.get(), rho, e, y, a, cs,
                                                                         d);
        CUDA_CHECK_LAUNCH();
        return;
      }
      const unsigned blocks = static_cast<unsigned>((n_ + kWarpsPerBlock - 1) / kWarpsPerBlock);
      auto run = [&](auto val, auto steps) {
        using Val = decltype(val);
        constexpr bool kSteps = decltype(steps)::value;
        sparse_rows_kernel<T, Val, kSteps><<<blocks, kBlock, 0, s_>>>(
            n_, reinterpret_cast<const int64_t*>(start_.get()), reinterpret_cast<const Val*>(data_.get()),
            kSteps ? nullptr : reinterpret_cast<const int32_t*>(index_.get()),
            kSteps ? reinterpret_cast<const uint16_t*>(index_.get()) : nullptr, x, y, rho, e, a, cs, d, cs_, ps_);
        CUDA_CHECK_LAUNCH();
      };
      auto with_steps = [&](auto val) {
        if (storage_ == FFStorage::compressed)
          run(val, std::true_type{});
        else
          run(val, std::false_type{});
      };
      switch (values_) {
        case FFValues::float32: with_steps(float{}); break;
        case FFValues::float16: with_steps(Half16{}); break;
        case FFValues::bfloat16: with_steps(BFloat16{}); break;
      }
    });
  }

  // The record's description of the product.
  std::string product() const {
    if (cusparse_) return "cusparseSpMM of csr float32, the three channels as one dense right-hand side";
    return std::string("own kernel, a warp per row, ") + to_string(storage_) + " " + to_string(values_) +
           (storage_ == FFStorage::compressed ? " (uint16 column steps)" : " (int32 columns)");
  }

 private:
  static constexpr double kSparseWorkspace = double(64 << 20);

  void copy_up(void* dst, const void* src, size_t bytes) {
    if (bytes > 0) CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyHostToDevice, s_));
  }

  // cuSPARSE's descriptors of F (int32 row starts and columns) and of x and p as n × 3 dense matrices in the
  // vectors' layout; its workspace.
  void describe(size_t entries) {
    handle_.emplace(s_);
    const int64_t n = int64_t(n_);
    CUSPARSE_CHECK(cusparseCreateCsr(&d_.A, n, n, int64_t(entries), start_.get(), index_.get(), data_.get(),
                                     CUSPARSE_INDEX_32I, CUSPARSE_INDEX_32I, CUSPARSE_INDEX_BASE_ZERO, CUDA_R_32F));
    const bool aos = ps_ != 1;  // AOS: records of 3, row-major; SOA: channels of `stride`, column-major
    const int64_t ld = aos ? 3 : int64_t(cs_);
    const cusparseOrder_t order = aos ? CUSPARSE_ORDER_ROW : CUSPARSE_ORDER_COL;
    CUSPARSE_CHECK(cusparseCreateDnMat(&d_.X, n, 3, ld, p_.get(), CUDA_R_32F, order));
    CUSPARSE_CHECK(cusparseCreateDnMat(&d_.P, n, 3, ld, p_.get(), CUDA_R_32F, order));
    const float one = 1, zero = 0;
    size_t bytes = 0;
    CUSPARSE_CHECK(cusparseSpMM_bufferSize(handle_->get(), CUSPARSE_OPERATION_NON_TRANSPOSE,
                                           CUSPARSE_OPERATION_NON_TRANSPOSE, &one, d_.A, d_.X, &zero, d_.P, CUDA_R_32F,
                                           CUSPARSE_SPMM_ALG_DEFAULT, &bytes));
    if (bytes > 0) work_.emplace(bytes);
  }

  size_t n_, cs_, ps_;
  double scale_;
  FFStorage storage_;
  FFValues values_;
  bool cusparse_;
  cudaStream_t s_;
  DeviceClock& clock_;
  hpcgi::DeviceArray<unsigned char> data_, index_, start_;  // values; columns or steps; row starts
  hpcgi::DeviceArray<T> p_;  // cuSPARSE's F x
  std::optional<hpcgi::SparseHandle> handle_;
  std::optional<hpcgi::DeviceArray<unsigned char>> work_;
  // cuSPARSE's descriptors, a member of their own so that they are destroyed even when describe() throws in the
  // constructor's body (then ~SparseDevice does not run, but its members' destructors do).
  struct Descriptors {
    cusparseSpMatDescr_t A = nullptr;
    cusparseDnMatDescr_t X = nullptr, P = nullptr;
    Descriptors() = default;
    Descriptors(const Descriptors&) = delete;
    Descriptors& operator=(const Descriptors&) = delete;
    ~Descriptors() {
      if (X) cusparseDestroyDnMat(X);
      if (P) cusparseDestroyDnMat(P);
      if (A) cusparseDestroySpMat(A);
    }
  } d_;
};

}  // namespace radiosity::gpu
