// Backend `cuda`: the report's CUDA column of Table 4.3 (§3.8.1, GPU off-loading): F, ρ, E and the vectors live on
// the GPU as {r, g, b} records, every operation is an own kernel (aos_kernels.cuh), and only the three sums of a
// reduction come back to the host. F in csr or compressed: its product by sparse_device.cuh (cuSPARSE for csr
// float32, our warp-per-row kernel otherwise), the records as its dense right-hand side.
#include <optional>

#include "radiosity/solve/gpu/aos_kernels.cuh"
#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/gpu/device_kernels.cuh"
#include "radiosity/solve/gpu/sparse_device.cuh"

namespace radiosity {
namespace {

template <class T>
class CudaAos final : public gpu::DeviceKernels<T> {
 public:
  CudaAos(const System& sys, int vectors) : n_(sys.n), dev_(sys, sys.n, vectors, this->stream_.get(), this->clock_) {
    if (sys.matrix.n && sys.matrix.storage != FFStorage::dense)
      sparse_.emplace(sys.matrix, 1, 3, 3 * n_, this->stream_.get(), this->clock_);
    matrix_bytes_ = sparse_ ? gpu::SparseDevice<T>::matrix_bytes(sys.matrix) : 4.0 * double(n_) * double(n_);
  }

  void upload(int v, const std::vector<Rgb>& x) override { dev_.upload(v, x); }
  void download(int v, std::vector<Rgb>& x) override {
    x.resize(n_);
    dev_.download(v, x, n_);
  }
  void matvec(int y, int x, double a, double c, double d) override {
    if (sparse_)
      sparse_->matvec(dev_.vec(x), dev_.vec(y), dev_.rho(), dev_.e(), T(a), T(c), T(d));
    else
      dev_.matvec(y, x, T(a), T(c), T(d));
  }
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
  double matrix_bytes() const override { return matrix_bytes_; }
  std::map<std::string, std::string> info() const override {
    auto i = gpu::DeviceKernels<T>::info();
    i["product"] = sparse_ ? sparse_->product() : "own kernel, dense float32, a warp per two rows";
    return i;
  }

 private:
  size_t n_;
  gpu::AosDevice<T> dev_;
  std::optional<gpu::SparseDevice<T>> sparse_;
  double matrix_bytes_ = 0;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_cuda(const System& sys, const SolveConfig& cfg, int vectors) {
  if (cfg.fused) throw hpcgi::UsageError("fused applies to backend cublas (its product is one pass over F already)");
  const std::string who = gpu::who("cuda", sys, cfg);
  hpcgi::require_gpu(who);
  const bool sparse = sys.matrix.n && sys.matrix.storage != FFStorage::dense;
  if (!sparse && !dense_float32(sys)) throw hpcgi::UsageError(who + ": dense form factors are read as the file's float32 values");
  hpcgi::require_device_memory(who, gpu::AosDevice<T>::bytes_needed(sys.n, sys.n, vectors, !sparse) +
                                        (sparse ? gpu::SparseDevice<T>::bytes_needed(sys.matrix, 3 * sys.n) : 0.0));
  return std::make_unique<CudaAos<T>>(sys, vectors);
}
template std::unique_ptr<Kernels<float>> make_cuda(const System&, const SolveConfig&, int);
template std::unique_ptr<Kernels<double>> make_cuda(const System&, const SolveConfig&, int);

}  // namespace radiosity
