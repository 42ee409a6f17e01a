// What the GPU backends of the solver share: their stream, pinned host memory, the clock that splits a run's
// time into upload, transfer and compute by CUDA events, and the description of the GPU for the record.
#pragma once
#include <algorithm>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "common/cuda_check.cuh"

namespace radiosity::gpu {

inline constexpr int kBlock = 256;  // threads per block of every kernel of the solver

// Blocks for a grid-stride loop over `work` items: enough to fill the GPU, never more than `cap`. The cap is a
// constant, not the GPU's SM count, so that a reduction adds its partial sums alike on every GPU.
inline unsigned grid_for(size_t work, size_t cap) {
  return static_cast<unsigned>(std::max<size_t>(1, std::min(cap, (work + kBlock - 1) / kBlock)));
}

// One stream per backend: kernels, cuBLAS calls and copies go through it in order, so no call has to
// synchronise with another, and the host waits only where it needs a result.
class Stream {
 public:
  Stream() { CUDA_CHECK(cudaStreamCreate(&s_)); }
  ~Stream() { cudaStreamDestroy(s_); }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return s_; }
  void sync() const { CUDA_CHECK(cudaStreamSynchronize(s_)); }

 private:
  cudaStream_t s_{};
};

using hpcgi::PinnedArray;  // common/cuda_check.cuh

struct DeviceTimes {
  double upload_s = 0, transfer_s = 0, compute_s = 0, host_compute_s = 0, transfer_bytes = 0;
};

// Where a device backend's time goes. Device work is timed by a pair of events around it on the stream, read
// only once the stream has passed them, so timing adds no synchronisation of its own; the host's share (hybrid's
// CPU rows) by the wall clock.
class DeviceClock {
 public:
  enum Kind { kUpload, kTransfer, kCompute, kKinds };
  explicit DeviceClock(cudaStream_t s) : s_(s) {}
  ~DeviceClock() {
    for (cudaEvent_t e : all_) cudaEventDestroy(e);
  }
  DeviceClock(const DeviceClock&) = delete;
  DeviceClock& operator=(const DeviceClock&) = delete;

  // Enqueues work() (calls that go to the stream) between two events; its time counts as `kind`.
  template <class Work>
  void timed(Kind kind, Work&& work) {
    cudaEvent_t start = take(), stop = take();
    CUDA_CHECK(cudaEventRecord(start, s_));
    work();
    CUDA_CHECK(cudaEventRecord(stop, s_));
    pending_.push_back({start, stop, kind});
    if (pending_.size() >= kMaxPending) collect();  // a long run without a synchronisation keeps few events
  }
  void host(double seconds) { host_s_ += seconds; }
  void moved(double bytes) { bytes_ += bytes; }

  // The totals so far; waits for the stream to finish what it was given.
  DeviceTimes totals() {
    CUDA_CHECK(cudaStreamSynchronize(s_));
    collect();
    return {seconds_[kUpload], seconds_[kTransfer], seconds_[kCompute], host_s_, bytes_};
  }

 private:
  static constexpr size_t kMaxPending = 256;
  struct Span {
    cudaEvent_t start, stop;
    Kind kind;
  };
  cudaEvent_t take() {
    if (free_.empty()) {
      cudaEvent_t e{};
      CUDA_CHECK(cudaEventCreate(&e));
      all_.push_back(e);
      return e;
    }
    cudaEvent_t e = free_.back();
    free_.pop_back();
    return e;
  }
  void collect() {
    for (const Span& p : pending_) {
      CUDA_CHECK(cudaEventSynchronize(p.stop));
      float ms = 0;
      CUDA_CHECK(cudaEventElapsedTime(&ms, p.start, p.stop));
      seconds_[p.kind] += 1e-3 * ms;
      free_.push_back(p.start);
      free_.push_back(p.stop);
    }
    pending_.clear();
  }

  cudaStream_t s_;
  std::vector<cudaEvent_t> all_, free_;  // all_ owns every event (also one left in flight by an exception)
  std::vector<Span> pending_;
  double seconds_[kKinds] = {0, 0, 0};
  double host_s_ = 0, bytes_ = 0;
};

using hpcgi::gpu_info;  // the GPU a backend runs on, for the record's backend_info (common/cuda_check.cuh)

}  // namespace radiosity::gpu
