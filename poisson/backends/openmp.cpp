// Shared-memory backend: the whole grid as one CpuBlock, OpenMP threads over its rows (the thread count is set by
// the driver before the backend is made, so the first touch already uses it).
#include <omp.h>

#include <string>

#include "poisson/contract/backends.hpp"
#include "poisson/backends/cpu_block.hpp"
#include "poisson/backends/cpu_pcg.hpp"

namespace poisson {
namespace {

template <class T>
class OpenMP final : public OneSweepKernels<T>, public Preconditioned {
 public:
  explicit OpenMP(const Config& cfg)
      : onesweep_(cfg.variant == Variant::onesweep), fmg_(cfg.method == Method::fmg), blk_(cfg.n, 0, cfg.n, fmg_) {
    if (!cfg.multigrid()) return;
    std::vector<LevelRows> rows;
    for (long m : mg_level_sizes(cfg.n)) rows.push_back({m, 0, m, true});
    pcg_ = std::make_unique<CpuPcg<T>>(blk_, rows, nullptr, fmg_);
  }
  double precondition() override { return pcg_->precondition(); }
  double solve_cycle(bool full) override { return pcg_->solve_cycle(full); }
  void calc_p_z(double beta) override { pcg_->calc_p_z(beta); }
  bool fused_updates() const override { return true; }
  double calc_p_pw(double beta) override { return pcg_->calc_p_pw(beta, [] {}); }
  double calc_ur_p(double alpha) override { return pcg_->calc_ur_p(alpha); }
  std::vector<long> mg_sizes() const override { return mg_level_sizes(blk_.rows()); }
  std::vector<double> fmg_vectors_per_level() const override {
    return poisson::fmg_vectors_per_level(blk_.rows(), kFusedLevelKernels);
  }
  double fmg_correction_vectors() const override { return 0; }  // the cycles run on x
  OneSweepKernels<T>* one_sweep() override { return this; }
  Preconditioned* multigrid() override { return this; }
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
  // classic: [w = Ap, p·w] 2, [x, r, r·r] 6, [p] 3; onesweep: read r, p, x and write them; multigrid:
  // [p = z + βp, p·Ap] 3, [x, r, r·r] with Ap from p 5 and the fused V-cycle, r·z in its last pass (mg.hpp);
  // fmg after its F-cycle: the solver's V-cycle on x itself, which also sums ‖b - Ax‖² (mg.hpp).
  int vectors_per_iteration() const override {
    return fmg_ ? static_cast<int>(mg_solve_vectors_per_cycle(blk_.rows()) + 0.5)
                : pcg_ ? 8 + mg_fused_vectors_per_cycle(blk_.rows()) : onesweep_ ? kVectorsOneSweep : kVectorsClassic;
  }
  std::map<std::string, std::string> info() const override {
    return {{"threads", std::to_string(omp_get_max_threads())}};
  }

 private:
  bool onesweep_, fmg_;
  CpuBlock<T> blk_;
  std::unique_ptr<CpuPcg<T>> pcg_;
};

}  // namespace

POISSON_BACKEND_FACTORY(make_openmp, OpenMP)

}  // namespace poisson
