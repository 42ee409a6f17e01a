// Backend `hybrid` (report §3.8.3, Table 4.5): Jacobi with the first g = ⌈d n⌉ rows of every step on the GPU
// (backend cuda's kernels, aos_kernels.cuh) and the other n - g on the CPU's OpenMP threads (backend openmp's code,
// hybrid_host.cpp), both at once: the kernel is launched, the CPU computes its rows meanwhile, then the halves are
// exchanged, the GPU's rows down to the host and the CPU's up to the device, so that both sides hold the whole new
// iterate for the next step.
//   default    as the report: the host synchronises the device, then copies from and to pageable memory;
//   --overlap  the GPU's rows go down to pinned memory by an async copy queued behind the kernel, so they travel
//              while the CPU is still computing its rows; the CPU's rows go up through pinned memory too.
// A side that computes no rows (d = 0 or 1) needs nothing from the other, so the ends copy nothing and compute
// exactly what backends openmp (d = 0) and cuda (d = 1) compute.
//
// Every kernel works on each side's own rows; only the product needs the other side's rows of its input. The
// product leaves its result whole on both sides; axpby and copy leave each side's rows new and the other side's
// stale, and the next product that reads such a slot exchanges it first (Jacobi never does: it runs only products
// and dist2).
#include <cmath>
#include <cstdio>
#include <cstring>

#include "common/timer.hpp"
#include "radiosity/solve/gpu/aos_kernels.cuh"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/gpu/device_kernels.cuh"
#include "radiosity/solve/gpu/hybrid_host.hpp"

namespace radiosity {
namespace {

using gpu::DeviceClock;

template <class T>
class Hybrid final : public gpu::DeviceKernels<T> {
 public:
  Hybrid(const System& sys, size_t rows_on_gpu, bool overlap, int threads, int vectors)
      : n_(sys.n), g_(rows_on_gpu), overlap_(overlap), dev_(sys, rows_on_gpu, vectors, s(), this->clock_),
        host_(sys, rows_on_gpu, vectors, threads), whole_(vectors, true),
        staging_(overlap && split() ? 3 * sys.n : 0) {}

  void upload(int v, const std::vector<Rgb>& x) override {
    host_.load(v, x);
    dev_.upload(v, x);
    whole_.at(v) = true;
  }
  void download(int v, std::vector<Rgb>& x) override {  // each side's own rows are the current ones
    x.resize(n_);
    dev_.download(v, x, g_);
    host_.store(v, x);
  }

  void matvec(int y, int x, double a, double c, double d) override {
    if (!whole_.at(x)) exchange(x);
    dev_.matvec(y, x, T(a), T(c), T(d));
    if (overlap_ && split()) gpu_rows_down_async(y);
    on_host([&] { host_.matvec(y, x, T(a), T(c), T(d)); });
    if (split()) {
      if (overlap_)
        finish_overlapped(y);
      else
        exchange_blocking(y);
    }
    whole_.at(y) = true;
  }
  Rgb dot(int x, int y) override { return reduce(false, x, y); }
  Rgb dist2(int x, int y) override { return reduce(true, x, y); }
  void axpby(int y, const Rgb& a, int x, const Rgb& b) override {
    dev_.axpby(y, a, x, b);
    on_host([&] { host_.axpby(y, a, x, b); });
    whole_.at(y) = false;
  }
  void copy(int y, int x) override {
    dev_.copy(y, x);
    on_host([&] { host_.copy(y, x); });
    whole_.at(y) = false;
  }
  int threads() const override { return host_.threads(); }
  double matrix_bytes() const override { return 4.0 * double(n_) * double(n_); }
  std::map<std::string, std::string> info() const override {
    auto i = gpu::DeviceKernels<T>::info();
    i["gpu_rows"] = std::to_string(g_);
    i["cpu_rows"] = std::to_string(n_ - g_);
    i["exchange"] = !split()    ? "none (one side has every row)"
                    : overlap_ ? "pinned staging, async copies overlapping the CPU's rows"
                               : "pageable, after synchronising the device (the report's)";
    return i;
  }

 private:
  cudaStream_t s() const { return this->stream_.get(); }
  bool split() const { return 0 < g_ && g_ < n_; }  // both sides have rows: they must exchange them
  size_t head_bytes() const { return 3 * g_ * sizeof(T); }
  size_t tail_bytes() const { return 3 * (n_ - g_) * sizeof(T); }

  template <class Work>
  void on_host(Work&& work) {
    hpcgi::Timer t;
    work();
    this->clock_.host(t.seconds());
  }

  // The GPU adds its rows while the CPU adds its own.
  Rgb reduce(bool diff, int x, int y) {
    dev_.reduce_start(diff, x, y);
    Rgb h{0, 0, 0};
    on_host([&] { h = diff ? host_.dist2(x, y) : host_.dot(x, y); });
    const Rgb g = dev_.reduce_result();
    return {g[0] + h[0], g[1] + h[1], g[2] + h[2]};
  }

  void exchange(int v) {
    if (split()) {
      if (overlap_) {
        gpu_rows_down_async(v);
        finish_overlapped(v);
      } else {
        exchange_blocking(v);
      }
    }
    whole_.at(v) = true;
  }

  // --overlap: the GPU's rows of slot v into the head of the staging buffer, queued on the stream.
  void gpu_rows_down_async(int v) {
    this->clock_.timed(DeviceClock::kTransfer, [&] {
      CUDA_CHECK(cudaMemcpyAsync(staging_.get(), dev_.vec(v), head_bytes(), cudaMemcpyDeviceToHost, s()));
    });
  }
  // --overlap, after the CPU's rows: they go up through the tail of the staging buffer (the head is the GPU's),
  // then the GPU's rows, arrived in the head, go into the host's vector.
  void finish_overlapped(int v) {
    T* h = host_.data(v);
    T* st = staging_.get();
    std::memcpy(st + 3 * g_, h + 3 * g_, tail_bytes());
    this->clock_.timed(DeviceClock::kTransfer, [&] {
      CUDA_CHECK(cudaMemcpyAsync(dev_.vec(v) + 3 * g_, st + 3 * g_, tail_bytes(), cudaMemcpyHostToDevice, s()));
    });
    CUDA_CHECK(cudaStreamSynchronize(s()));
    std::memcpy(h, st, head_bytes());
    this->clock_.moved(head_bytes() + tail_bytes());
  }
  // The report's exchange: synchronise the device, then copy from and to the host's (pageable) vector.
  void exchange_blocking(int v) {
    T* h = host_.data(v);
    CUDA_CHECK(cudaStreamSynchronize(s()));
    this->clock_.timed(DeviceClock::kTransfer, [&] {
      CUDA_CHECK(cudaMemcpyAsync(h, dev_.vec(v), head_bytes(), cudaMemcpyDeviceToHost, s()));
      CUDA_CHECK(cudaMemcpyAsync(dev_.vec(v) + 3 * g_, h + 3 * g_, tail_bytes(), cudaMemcpyHostToDevice, s()));
    });
    CUDA_CHECK(cudaStreamSynchronize(s()));
    this->clock_.moved(head_bytes() + tail_bytes());
  }

  size_t n_, g_;
  bool overlap_;
  gpu::AosDevice<T> dev_;
  HostRows<T> host_;
  std::vector<bool> whole_;  // per slot: both sides hold every row's current value
  gpu::PinnedArray<T> staging_;
};

void check_distribution(double d) {
  if (!(d >= 0 && d <= 1)) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "distribution must be in [0, 1] (the share of rows on the GPU), got %g", d);
    throw hpcgi::UsageError(buf);
  }
}

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_hybrid(const System& sys, const SolveConfig& cfg, int vectors) {
  if (cfg.fused) throw hpcgi::UsageError("fused applies to backend cublas (hybrid runs backend cuda's kernels)");
  check_distribution(cfg.distribution);
  const std::string who = gpu::who("hybrid", sys, cfg);
  hpcgi::require_gpu(who);
  if (!dense_float32(sys)) throw hpcgi::UsageError(who + ": dense form factors are read as the file's float32 values");
  const size_t g = gpu_rows(sys.n, cfg.distribution);
  hpcgi::require_device_memory(who + " with " + std::to_string(g) + " rows on the GPU",
                               gpu::AosDevice<T>::bytes_needed(sys.n, g, vectors));
  return std::make_unique<Hybrid<T>>(sys, g, cfg.overlap, cfg.threads, vectors);
}
template std::unique_ptr<Kernels<float>> make_hybrid(const System&, const SolveConfig&, int);
template std::unique_ptr<Kernels<double>> make_hybrid(const System&, const SolveConfig&, int);

}  // namespace radiosity
