// The GPU backends' tests' shared pieces (test_cuda.cpp, test_cuda_sparse.cpp, test_cuda_refusals.cpp): whether a
// GPU backend can run here (SKIP_WITHOUT_GPU), every GPU configuration the registry runs, their solve configurations
// and the serial float64 reference's, and the comparisons.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/solve/solve.hpp"
#include "configs.hpp"
#include "reference.hpp"

namespace cuda_test {

using namespace radiosity;
using namespace solve_test;

inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// Why a GPU backend cannot run here (the backend's own refusal: no GPU, or a build without CUDA), or "" when it can.
inline const std::string& gpu_absent() {
  static const std::string why = [] {
    const Problem p = random_problem(8, 1);
    SolveConfig c;
    c.backend = "cuda";
    c.steps = 1;
    try {
      solve(p.sys, c);
      return std::string();
    } catch (const hpcgi::UsageError& e) {
      const std::string what = e.what();
      return contains(what, "needs an NVIDIA GPU") || contains(what, "is not available") ? what : std::string();
    }
  }();
  return why;
}
#define SKIP_WITHOUT_GPU()                                                          \
  do {                                                                              \
    if (!gpu_absent().empty()) GTEST_SKIP() << "the GPU backends cannot run here: " << gpu_absent(); \
  } while (0)

// A GPU configuration as the registry runs it.
struct Gpu {
  std::string label, backend, layout;
  bool fused = false;
  double distribution = 0.5;
  bool overlap = false;
};
inline const std::vector<Gpu>& every_gpu_config() {
  static const std::vector<Gpu> all = {
      {"cuda", "cuda", "aos"},
      {"cublas", "cublas", "soa"},
      {"cublas fused", "cublas", "soa", true},
      {"hybrid d=0", "hybrid", "aos", false, 0.0},
      {"hybrid d=0.3", "hybrid", "aos", false, 0.3},
      {"hybrid d=0.3 overlap", "hybrid", "aos", false, 0.3, true},
      {"hybrid d=1", "hybrid", "aos", false, 1.0},
  };
  return all;
}

inline SolveConfig config(const Gpu& g, const std::string& method, const std::string& precision, long steps) {
  SolveConfig c = solve_config(g.backend, g.layout, method, precision, steps);
  c.tol = 1e-6;
  c.fused = g.fused;
  c.distribution = g.distribution;
  c.overlap = g.overlap;
  c.max_iter = 5000;
  return c;
}

inline SolveConfig serial_double(const std::string& method, long steps) {
  SolveConfig c = solve_config("serial", "aos", method, "double", steps);
  c.max_iter = 10000;
  return c;
}

inline double bound(const std::string& precision) { return precision == "float" ? 1e-5 : 1e-12; }

#ifdef HAVE_CUDA
inline std::vector<Rgb> random_vector(size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Rgb> v(n);
  for (Rgb& x : v)
    for (double& c : x) c = u(rng);
  return v;
}
#endif

// max |x - y| over max |y|.
inline double max_rel(const std::vector<Rgb>& x, const std::vector<Rgb>& y) {
  double num = 0, den = 0;
  for (size_t i = 0; i < y.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      num = std::max(num, std::abs(x[i][c] - y[i][c]));
      den = std::max(den, std::abs(y[i][c]));
    }
  return num / den;
}

}  // namespace cuda_test
