// Backend `cuda`: the report's CUDA column of Table 4.3 (§3.8.1, GPU off-loading): F, ρ, E and the vectors live on
// the GPU as {r, g, b} records, every operation is an own kernel (aos_kernels.cuh), and only the three sums of a
// reduction come back to the host.
#include "radiosity/solve/gpu/aos_kernels.cuh"
#include "radiosity/solve/backends.hpp"
#include "radiosity/solve/gpu/device_kernels.cuh"

namespace radiosity {
namespace {

template <class T>
class CudaAos final : public gpu::DeviceKernels<T> {
 public:
  CudaAos(const System& sys, int vectors) : n_(sys.n), dev_(sys, sys.n, vectors, this->stream_.get(), this->clock_) {}

  void upload(int v, const std::vector<Rgb>& x) override { dev_.upload(v, x); }
  void download(int v, std::vector<Rgb>& x) override {
    x.resize(n_);
    dev_.download(v, x, n_);
  }
  void matvec(int y, int x, double a, double c, double d) override { dev_.matvec(y, x, T(a), T(c), T(d)); }
  Rgb dot(int x, int y) override {
    dev_.reduce_start(false, x, y);
    return dev_.reduce_result();
  }
  Rgb dist2(int x, int y) override {
    dev_.reduce_start(true, x, y);
    return dev_.reduce_result();
  }
  void axpby(int y, const Rgb& a, int x, const Rgb& b) override { dev_.axpby(y, a, x, b); }
  void copy(int y, int x) override { dev_.copy(y, x); }
  int threads() const override { return 1; }
  double matrix_bytes() const override { return 4.0 * double(n_) * double(n_); }

 private:
  size_t n_;
  gpu::AosDevice<T> dev_;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_cuda(const System& sys, const SolveConfig& cfg, int vectors) {
  if (cfg.fused) throw hpcgi::UsageError("fused applies to backend cublas (its product is one pass over F already)");
  const std::string who = gpu::who("cuda", sys, cfg);
  hpcgi::require_gpu(who);
  hpcgi::require_device_memory(who, gpu::AosDevice<T>::bytes_needed(sys.n, sys.n, vectors));
  return std::make_unique<CudaAos<T>>(sys, vectors);
}
template std::unique_ptr<Kernels<float>> make_cuda(const System&, const SolveConfig&, int);
template std::unique_ptr<Kernels<double>> make_cuda(const System&, const SolveConfig&, int);

}  // namespace radiosity
