// Shared-memory backend: the whole grid as one CpuBlock, OpenMP threads over its rows (the thread count is set by
// the driver before the backend is made, so the first touch already uses it).
#include <omp.h>

#include <string>

#include "poisson/backends.hpp"
#include "poisson/cpu_block.hpp"

namespace poisson {
namespace {

template <class T>
class OpenMP final : public OneSweepKernels<T> {
 public:
  explicit OpenMP(const Config& cfg) : onesweep_(cfg.variant == "onesweep"), blk_(cfg.n, 0, cfg.n) {}
  double init() override { return blk_.init(); }
  double calc_w() override { return blk_.calc_w(); }
  double calc_ur(double alpha) override { return blk_.calc_ur(alpha); }
  void calc_p(double beta) override { blk_.calc_p(beta); }
  double r_Ar() override { return blk_.r_Ar(); }
  SweepDots sweep(double alpha, double beta) override { return blk_.sweep(alpha, beta); }
  double true_residual2() override { return blk_.true_residual2(); }
  double error_inf() override { return blk_.error_inf(); }
  std::vector<double> solution() override {
    std::vector<double> out(blk_.rows() * (blk_.stride() - 2));
    blk_.copy_x(out.data());
    return out;
  }
  // classic: [w = Ap, p·w] 2, [x, r, r·r] 6, [p] 3; onesweep: read r, p, x and write them.
  int vectors_per_iteration() const override { return onesweep_ ? 6 : 11; }
  std::map<std::string, std::string> info() const override {
    return {{"threads", std::to_string(omp_get_max_threads())}};
  }

 private:
  bool onesweep_;
  CpuBlock<T> blk_;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_openmp(const Config& cfg) {
  return std::make_unique<OpenMP<T>>(cfg);
}
template std::unique_ptr<Kernels<float>> make_openmp(const Config&);
template std::unique_ptr<Kernels<double>> make_openmp(const Config&);

}  // namespace poisson
