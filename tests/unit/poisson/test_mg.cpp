// CG preconditioned by the multigrid V-cycle (mg.hpp, --precond mg) on the CPU backends in one process: flat
// iterations for odd and even N, a symmetric preconditioner, the same solution as plain CG (the same error
// against the exact solution), second order, openmp taking the same steps as the serial reference.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "poisson/methods/cg.hpp"
#include "poisson/contract/kernels.hpp"
#include "poisson/methods/mg.hpp"

namespace {

poisson::Config config(const std::string& backend, long n, const std::string& precond = "mg") {
  poisson::Config cfg;
  cfg.n = n;
  cfg.backend = poisson::parse_backend(backend);
  cfg.precond = poisson::parse_precond(precond);
  cfg.variant = poisson::Variant::classic;
  return cfg;
}

template <class T = double>
poisson::CgResult solve(const std::string& backend, long n, double tol = 1e-6, const std::string& precond = "mg") {
  const poisson::Config cfg = config(backend, n, precond);
  auto k = poisson::make_kernels<T>(cfg);
  return poisson::run_config(*k, cfg, tol, 100000);
}

std::string three_digits(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%.2e", v);
  return s;
}

struct Threads {
  explicit Threads(int t) : old(omp_get_max_threads()) { omp_set_num_threads(t); }
  ~Threads() { omp_set_num_threads(old); }
  int old;
};

TEST(Mg, HierarchyHalvesDownToOne) {
  EXPECT_EQ(poisson::mg_level_sizes(1), (std::vector<long>{1}));
  EXPECT_EQ(poisson::mg_level_sizes(31), (std::vector<long>{31, 15, 7, 3, 1}));
  EXPECT_EQ(poisson::mg_level_sizes(32), (std::vector<long>{32, 16, 8, 4, 2, 1}));
  // Odd levels keep the boundary at H from the last point (no change to the diagonal); an even level puts the
  // next one's at H/2 (diagonal + 1), then H/4 (+ 3).
  EXPECT_EQ(poisson::mg_edge_terms(31), (std::vector<double>{0, 0, 0, 0, 0}));
  EXPECT_EQ(poisson::mg_edge_terms(8), (std::vector<double>{0, 1, 3, 7}));
  EXPECT_EQ(poisson::mg_edge_terms(9), (std::vector<double>{0, 0, 1, 3}));  // 9 -> 4 (odd) -> 2 -> 1
}

// At most 12 iterations to 1e-6 for every N of the list, odd and even, and flat: the largest N takes at
// most 2 more than the smallest. openmp takes the same steps as the serial reference.
TEST(Mg, IterationsAreFewAndFlatInNOnEveryCpuBackend) {
  std::vector<long> iters;
  for (long n : {31L, 32L, 63L, 64L, 127L, 128L, 255L, 256L, 511L, 512L, 1023L, 1024L}) {
    const poisson::CgResult s = solve("serial", n);
    EXPECT_EQ(s.status, poisson::Status::converged) << n;
    EXPECT_LE(s.iterations, 12) << n;
    EXPECT_LE(s.true_rel_residual, 1e-6) << n;
    for (int t : {1, 2, 3}) {
      Threads th(t);
      const poisson::CgResult o = solve("openmp", n);
      EXPECT_EQ(o.iterations, s.iterations) << "n=" << n << " threads=" << t;
      EXPECT_NEAR(o.error_inf, s.error_inf, 1e-6 * s.error_inf) << n;  // rounding apart
    }
    iters.push_back(s.iterations);
  }
  EXPECT_LE(iters.back(), iters.front() + 2);
}

TEST(Mg, AnyNFromOne) {
  for (long n = 1; n <= 20; ++n) {
    const poisson::CgResult s = solve("serial", n, 1e-10);
    EXPECT_EQ(s.status, poisson::Status::converged) << n;
    EXPECT_LE(s.iterations, 12) << n;
    const poisson::CgResult c = solve("serial", n, 1e-10, "none");
    EXPECT_NEAR(s.error_inf, c.error_inf, 1e-8 * c.error_inf) << n;  // the same discrete solution
  }
  EXPECT_EQ(solve("serial", 1).iterations, 1);  // one level, solved exactly
}

// (M⁻¹x)·y = x·(M⁻¹y) for random x, y: the V-cycle with red-black forward before and backward after is
// symmetric. (Post-smoothing in the same order, red then black, gives 2e-2 at N = 100: the check can fail.)
TEST(Mg, PreconditionerIsSymmetric) {
  for (const char* backend : {"serial", "openmp"})
    for (long n : {7L, 32L, 100L, 257L}) {
      auto k = poisson::make_kernels<double>(config(backend, n));
      auto* m = dynamic_cast<poisson::Preconditioned*>(k.get());
      ASSERT_NE(m, nullptr);
      EXPECT_LE(poisson::mg_asymmetry(*m, n), 1e-12) << backend << " n=" << n;
    }
}

// The preconditioned solve reaches the same discrete solution: ‖u − u_h‖∞ equals plain CG's to 3 significant
// digits (and at N = 1024 the value PETSc's CG also gives, 3.1266e-6: ../shared/notes/petsc-peer.md).
TEST(Mg, ErrorEqualsPlainCgsToThreeDigits) {
  Threads th(2);
  for (long n : {512L, 1024L}) {
    poisson::Config cfg = config("openmp", n, "none");
    cfg.variant = poisson::Variant::onesweep;
    auto k = poisson::make_kernels<double>(cfg);
    const poisson::CgResult plain = poisson::run_config(*k, cfg, 1e-6, 100000);
    const poisson::CgResult mg = solve("openmp", n);
    EXPECT_EQ(three_digits(mg.error_inf), three_digits(plain.error_inf)) << n;
    if (n == 1024) {
      EXPECT_EQ(three_digits(plain.error_inf), three_digits(3.1266e-6));
      EXPECT_EQ(three_digits(mg.error_inf), three_digits(3.1266e-6));
    }
  }
}

// Second order: halving h (N = 31, 63, 127, 255) quarters the error, with MG-PCG to 1e-10.
TEST(Mg, DiscretisationErrorIsSecondOrder) {
  std::vector<double> e;
  for (long n : {31L, 63L, 127L, 255L}) e.push_back(solve("openmp", n, 1e-10).error_inf);
  for (size_t k = 1; k < e.size(); ++k) EXPECT_NEAR(e[k - 1] / e[k], 4.0, 0.3) << k;
}

// In float x cannot hold the h²-scaled solution to better than its rounding (as plain CG, whose float error at
// N = 256 is within 1% of double's): the recursive residual converges, the error is 6% above double's here.
TEST(Mg, FloatConverges) {
  const poisson::CgResult f = solve<float>("openmp", 256);
  const poisson::CgResult d = solve("openmp", 256);
  EXPECT_EQ(f.status, poisson::Status::converged);
  EXPECT_LE(f.iterations, d.iterations + 2);
  EXPECT_NEAR(f.error_inf, d.error_inf, 0.1 * d.error_inf);
}

TEST(Mg, PreconditionerABackendLacksIsAUsageError) {
  EXPECT_THROW(poisson::parse_precond("ilu"), hpcgi::UsageError);
  poisson::Config cfg = config("openmp", 8);
  cfg.variant = poisson::Variant::onesweep;
  EXPECT_THROW(poisson::make_kernels<double>(cfg), hpcgi::UsageError);
  using poisson::Backend, poisson::Precision, poisson::Precond, poisson::Variant;
  EXPECT_EQ(poisson::default_variant(Backend::openmp, Precision::double_, Precond::mg), Variant::classic);
  EXPECT_EQ(poisson::default_variant(Backend::openmp, Precision::double_, Precond::none, poisson::Method::fmg),
            Variant::classic);
#ifdef HAVE_CUDA
  EXPECT_THROW(poisson::make_kernels<double>(config("cublas1", 8)), hpcgi::UsageError);
#endif
}

}  // namespace

// --method fmg's data-movement model (mg.hpp): 9 vectors of N² on the finest level (restriction of b and
// interpolation 2.5, the one-pass halves of the V-cycle from x 6.5), each level below its own share plus 5.5 for
// every cycle from zero that passes through it, scaled by its size; a solver V-cycle is 6.5 on the finest level
// and 5.5 on each coarser one.
TEST(Mg, FmgBytesModelByLevel) {
  const std::vector<double> v = poisson::fmg_vectors_per_level(64, poisson::kFusedLevelKernels);
  ASSERT_EQ(v.size(), 7u);
  EXPECT_DOUBLE_EQ(v[0], 9.0);
  EXPECT_DOUBLE_EQ(v[1], (9.0 + 5.5) * (32.0 / 64) * (32.0 / 64));
  EXPECT_DOUBLE_EQ(v[6], 6 * 5.5 * (1.0 / 64) * (1.0 / 64));  // the coarsest: only the cycles from zero
  double total = 0;
  for (double x : v) total += x;
  EXPECT_LT(total, 9.0 * 4 / 3 + 5.5);  // about 4/3 of the finest level's share and one cycle from zero
  double cycle = 6.5;
  for (long m = 32; m >= 1; m /= 2) cycle += 5.5 * (m / 64.0) * (m / 64.0);
  EXPECT_DOUBLE_EQ(poisson::mg_solve_vectors_per_cycle(64), cycle);
}

// The same model for MgLevels' separate kernels (serial, cuda), from the costs of mg_vectors_per_cycle: 23 vectors of
// N² on the finest level (restrict_rhs 5.25 and interpolate 3.25, the V-cycle from x 14.5), 15.5 for each cycle from
// zero below; a cycle from zero on every level is mg_vectors_per_cycle's 15.5 per level.
TEST(Mg, FmgBytesModelOfSeparateLevelKernels) {
  const std::vector<double> v = poisson::fmg_vectors_per_level(64, poisson::kSeparateLevelKernels);
  ASSERT_EQ(v.size(), 7u);
  EXPECT_DOUBLE_EQ(v[0], 23.0);
  EXPECT_DOUBLE_EQ(v[1], (23.0 + 15.5) * (32.0 / 64) * (32.0 / 64));
  EXPECT_DOUBLE_EQ(v[6], 6 * 15.5 * (1.0 / 64) * (1.0 / 64));
  double cycle = 0;
  for (long m = 64; m >= 1; m /= 2) cycle += poisson::kSeparateLevelKernels.cycle_from_zero * (m / 64.0) * (m / 64.0);
  EXPECT_EQ(poisson::mg_vectors_per_cycle(64), static_cast<int>(cycle + 0.5));
}
