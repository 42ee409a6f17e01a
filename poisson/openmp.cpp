// Shared-memory backend: the whole grid as one CpuBlock, OpenMP threads over its rows (the thread count is set by
// the driver before the backend is made, so the first touch already uses it).
#include <omp.h>

#include <string>

#include "poisson/backends.hpp"
#include "poisson/cpu_block.hpp"
#include "poisson/mg_cpu.hpp"

namespace poisson {
namespace {

template <class T>
class OpenMP final : public OneSweepKernels<T>, public Preconditioned {
 public:
  explicit OpenMP(const Config& cfg) : onesweep_(cfg.variant == "onesweep"), blk_(cfg.n, 0, cfg.n) {
    if (cfg.precond != "mg") return;
    std::vector<LevelRows> rows;
    for (long m : mg_level_sizes(cfg.n)) rows.push_back({m, 0, m, true});
    pcg_ = std::make_unique<CpuPcg<T>>(blk_, rows, nullptr);
  }
  double precondition() override { return pcg_->precondition(); }
  void calc_p_z(double beta) override { pcg_->calc_p_z(beta); }
  std::vector<long> mg_sizes() const override { return mg_level_sizes(blk_.rows()); }
  double apply_dot(const GridFn& x, const GridFn& y) override { return pcg_->apply_dot(x, y, 0); }
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
  // classic: [w = Ap, p·w] 2, [x, r, r·r] 6, [p] 3; onesweep: read r, p, x and write them; multigrid: classic
  // with [p = z + βp] 3 for [p], [r·z] 2 and the V-cycle (mg.hpp).
  int vectors_per_iteration() const override {
    return pcg_ ? 11 + 2 + mg_vectors_per_cycle(blk_.rows()) : onesweep_ ? 6 : 11;
  }
  std::map<std::string, std::string> info() const override {
    return {{"threads", std::to_string(omp_get_max_threads())}};
  }

 private:
  bool onesweep_;
  CpuBlock<T> blk_;
  std::unique_ptr<CpuPcg<T>> pcg_;
};

}  // namespace

template <class T>
std::unique_ptr<Kernels<T>> make_openmp(const Config& cfg) {
  return std::make_unique<OpenMP<T>>(cfg);
}
template std::unique_ptr<Kernels<float>> make_openmp(const Config&);
template std::unique_ptr<Kernels<double>> make_openmp(const Config&);

}  // namespace poisson
