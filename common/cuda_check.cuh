// Every CUDA, cuBLAS and cuSPARSE call of the project goes through these checks; a failure throws with the call, the file
// and the line. Kernel launches are followed by CUDA_CHECK_LAUNCH().
#pragma once
#include <cublas_v2.h>
#include <cuda_runtime.h>
#include <cusparse.h>

#include <map>
#include <stdexcept>
#include <string>

#include "common/errors.hpp"

namespace hpcgi {

[[noreturn]] inline void cuda_fail(const char* call, const char* msg, const char* file, int line) {
  throw std::runtime_error(std::string("CUDA: ") + call + " failed: " + msg + " (" + file + ":" +
                           std::to_string(line) + ")");
}

#define CUDA_CHECK(call)                                                                       \
  do {                                                                                         \
    cudaError_t err_ = (call);                                                                 \
    if (err_ != cudaSuccess) ::hpcgi::cuda_fail(#call, cudaGetErrorString(err_), __FILE__, __LINE__); \
  } while (0)

#define CUDA_CHECK_LAUNCH() CUDA_CHECK(cudaGetLastError())

#define CUBLAS_CHECK(call)                                                                        \
  do {                                                                                            \
    cublasStatus_t st_ = (call);                                                                  \
    if (st_ != CUBLAS_STATUS_SUCCESS)                                                             \
      ::hpcgi::cuda_fail(#call, cublasGetStatusString(st_), __FILE__, __LINE__);                 \
  } while (0)

#define CUSPARSE_CHECK(call)                                                                      \
  do {                                                                                            \
    cusparseStatus_t st_ = (call);                                                                \
    if (st_ != CUSPARSE_STATUS_SUCCESS)                                                           \
      ::hpcgi::cuda_fail(#call, cusparseGetErrorString(st_), __FILE__, __LINE__);                \
  } while (0)

// Throws UsageError (exit status 2) when no usable GPU is present, naming what CUDA said. Counting devices is not
// enough: a GPU that is present but cannot be used (no fabric manager on a multi-GPU board, exclusive-process mode
// taken by another process, a driver too old for this runtime) is only found out when a context is made, so the
// check makes the primary context of the current device here (cudaFree(nullptr)). Every caller's next CUDA call
// would make it anyway.
inline void require_gpu(const std::string& who) {
  int count = 0;
  cudaError_t err = cudaGetDeviceCount(&count);
  if (err != cudaSuccess || count == 0) {
    cudaGetLastError();  // clear the sticky error
    throw UsageError(who + " needs an NVIDIA GPU, and none is usable here (" +
                     (err != cudaSuccess ? std::string(cudaGetErrorString(err)) : std::string("no device")) + ")");
  }
  err = cudaFree(nullptr);
  if (err != cudaSuccess) {
    cudaGetLastError();
    throw UsageError(who + " needs an NVIDIA GPU, and none is usable here (" + std::to_string(count) +
                     " device(s) found, but no context could be made on device 0: " + cudaGetErrorString(err) + ")");
  }
}

// The current GPU, for a record's backend_info: model, compute capability, memory, clocks, runtime and driver.
inline std::map<std::string, std::string> gpu_info() {
  int dev = 0, rt = 0, drv = 0, clock_khz = 0, mem_clock_khz = 0, bus_bits = 0, sms = 0;
  cudaDeviceProp prop{};
  CUDA_CHECK(cudaGetDevice(&dev));
  CUDA_CHECK(cudaGetDeviceProperties(&prop, dev));
  CUDA_CHECK(cudaRuntimeGetVersion(&rt));
  CUDA_CHECK(cudaDriverGetVersion(&drv));
  CUDA_CHECK(cudaDeviceGetAttribute(&clock_khz, cudaDevAttrClockRate, dev));
  CUDA_CHECK(cudaDeviceGetAttribute(&mem_clock_khz, cudaDevAttrMemoryClockRate, dev));
  CUDA_CHECK(cudaDeviceGetAttribute(&bus_bits, cudaDevAttrGlobalMemoryBusWidth, dev));
  CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
  return {{"gpu", prop.name},
          {"gpu_cc", std::to_string(prop.major) + "." + std::to_string(prop.minor)},
          {"gpu_memory_GiB", std::to_string(static_cast<double>(prop.totalGlobalMem) / (1 << 30))},
          {"gpu_sms", std::to_string(sms)},
          {"gpu_clock_MHz", std::to_string(clock_khz / 1000)},
          {"gpu_memory_clock_MHz", std::to_string(mem_clock_khz / 1000)},
          {"gpu_memory_bus_bits", std::to_string(bus_bits)},
          {"cuda_runtime", std::to_string(rt)},
          {"cuda_driver", std::to_string(drv)}};
}

// Throws UsageError when `bytes` will not fit in the free memory of the current GPU.
inline void require_device_memory(const std::string& who, double bytes) {
  size_t free_b = 0, total_b = 0;
  CUDA_CHECK(cudaMemGetInfo(&free_b, &total_b));
  if (bytes > static_cast<double>(free_b))
    throw UsageError(who + " needs " + std::to_string(bytes / (1 << 30)) + " GiB of GPU memory, and the GPU has " +
                     std::to_string(static_cast<double>(free_b) / (1 << 30)) + " GiB free of " +
                     std::to_string(static_cast<double>(total_b) / (1 << 30)) + " GiB");
}

// An owning device array.
template <class T>
class DeviceArray {
 public:
  explicit DeviceArray(size_t n) : n_(n) { CUDA_CHECK(cudaMalloc(&p_, n * sizeof(T))); }
  ~DeviceArray() { cudaFree(p_); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  T* get() const { return p_; }
  size_t size() const { return n_; }

 private:
  T* p_ = nullptr;
  size_t n_;
};

// Page-locked host memory: copies from and to it are truly asynchronous (pageable memory is staged by the driver,
// which blocks the host). An owner, so a member of this type is freed when a later member's allocation throws.
template <class T>
class PinnedArray {
 public:
  explicit PinnedArray(size_t n) {
    if (n > 0) CUDA_CHECK(cudaMallocHost(&p_, n * sizeof(T)));
  }
  ~PinnedArray() {
    if (p_) cudaFreeHost(p_);
  }
  PinnedArray(const PinnedArray&) = delete;
  PinnedArray& operator=(const PinnedArray&) = delete;
  T* get() const { return p_; }

 private:
  T* p_ = nullptr;
};

// A cuBLAS handle that lives as long as its owner: its calls go to `stream` (default: the legacy default stream),
// scalars (alpha, a dot's result) are read from and written to `scalars` (host or device memory), and the math mode
// is the default: full precision, no TF32.
class BlasHandle {
 public:
  explicit BlasHandle(cudaStream_t stream = nullptr, cublasPointerMode_t scalars = CUBLAS_POINTER_MODE_HOST) {
    CUBLAS_CHECK(cublasCreate(&h_));
    try {
      CUBLAS_CHECK(cublasSetStream(h_, stream));
      CUBLAS_CHECK(cublasSetPointerMode(h_, scalars));
      CUBLAS_CHECK(cublasSetMathMode(h_, CUBLAS_DEFAULT_MATH));
    } catch (...) {
      cublasDestroy(h_);
      throw;
    }
  }
  ~BlasHandle() { cublasDestroy(h_); }
  BlasHandle(const BlasHandle&) = delete;
  BlasHandle& operator=(const BlasHandle&) = delete;
  cublasHandle_t get() const { return h_; }

 private:
  cublasHandle_t h_{};
};

// A cuSPARSE handle that lives as long as its owner, its calls on `stream`.
class SparseHandle {
 public:
  explicit SparseHandle(cudaStream_t stream = nullptr) {
    CUSPARSE_CHECK(cusparseCreate(&h_));
    try {
      CUSPARSE_CHECK(cusparseSetStream(h_, stream));
    } catch (...) {
      cusparseDestroy(h_);
      throw;
    }
  }
  ~SparseHandle() { cusparseDestroy(h_); }
  SparseHandle(const SparseHandle&) = delete;
  SparseHandle& operator=(const SparseHandle&) = delete;
  cusparseHandle_t get() const { return h_; }

 private:
  cusparseHandle_t h_{};
};

}  // namespace hpcgi
