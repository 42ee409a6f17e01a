// Not a test: the time of one Jacobi step on the report's scene-3 size (n = 9680) with a random F, and the
// bandwidth it implies (4n² bytes of F per step; the vectors stay in cache). Disabled by default; run with
//   build-solve/tests/solve_tests --gtest_also_run_disabled_tests --gtest_filter='SolveBench.*'
// OMP_NUM_THREADS is not read: the threads are set here (2).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "common/timer.hpp"
#include "radiosity/solve/solve.hpp"

using namespace radiosity;

namespace {

constexpr size_t kN = 9680;
constexpr int kThreads = 2;
constexpr long kSteps = 8;
constexpr int kRepeats = 5;

struct Bench {
  std::vector<float> F;
  System sys;
};

// F_ij uniform in [0, 2·0.95/n): rows sum to about 0.95. A 64-bit LCG per row keeps set-up to a second.
Bench make_bench() {
  Bench b;
  b.F.resize(kN * kN);
#pragma omp parallel for schedule(static) num_threads(kThreads)
  for (size_t i = 0; i < kN; ++i) {
    uint64_t s = 0x9E3779B97F4A7C15ull * (i + 1);
    for (size_t j = 0; j < kN; ++j) {
      s = s * 6364136223846793005ull + 1442695040888963407ull;
      b.F[i * kN + j] = i == j ? 0.0f : float((s >> 40) * (1.0 / 16777216.0) * 2 * 0.95 / kN);
    }
  }
  b.sys.n = kN;
  b.sys.matrix = dense_float32_view(b.F.data(), b.sys.n);
  b.sys.emission.assign(kN, Rgb{0, 0, 0});
  for (size_t i = 0; i < kN; i += 10) b.sys.emission[i] = {1, 0.8, 0.6};
  b.sys.reflectivity.assign(kN, Rgb{0.7, 0.6, 0.5});
  b.sys.initial = b.sys.emission;
  return b;
}

// Seconds per step, the best of kRepeats runs of `steps` steps.
double step_seconds(const System& sys, const std::string& backend, const std::string& layout, long steps) {
  SolveConfig c;
  c.backend = backend;
  c.layout = parse_layout(layout);
  c.precision = Precision::single;
  c.steps = steps;
  c.threads = kThreads;
  double best = 1e30;
  for (int r = 0; r < kRepeats; ++r) best = std::min(best, solve(sys, c).solve_s / double(steps));
  return best;
}

// What the memory gives a plain read of the same 4n² bytes with the same threads: the ceiling to compare with.
double read_seconds(const std::vector<float>& F) {
  double best = 1e30, sink = 0;
  for (int r = 0; r < kRepeats; ++r) {
    hpcgi::Timer t;
    float s = 0;
#pragma omp parallel for simd schedule(static) num_threads(kThreads) reduction(+ : s)
    for (size_t k = 0; k < F.size(); ++k) s += F[k];
    best = std::min(best, t.seconds());
    sink += s;
  }
  EXPECT_GT(sink, 0);
  return best;
}

}  // namespace

TEST(SolveBench, DISABLED_JacobiStepBandwidth) {
  const Bench b = make_bench();
  const double bytes = 4.0 * double(kN) * double(kN);
  auto report = [&](const char* what, double s) {
    std::printf("%-28s %9.2f ms/step  %6.2f GB/s (4n^2 bytes / time)\n", what, 1e3 * s, bytes / s / 1e9);
    RecordProperty(what, std::to_string(s));
  };
  std::printf("n = %zu, float, %d threads, best of %d runs of %ld steps\n", kN, kThreads, kRepeats, kSteps);
  report("read F (ceiling)", read_seconds(b.F));
  report("openmp aos", step_seconds(b.sys, "openmp", "aos", kSteps));
  report("openmp soa", step_seconds(b.sys, "openmp", "soa", kSteps));
  report("serial aos", step_seconds(b.sys, "serial", "aos", kSteps));
  report("serial soa", step_seconds(b.sys, "serial", "soa", kSteps));
  report("original (1 thread)", step_seconds(b.sys, "original", "aos", 2));
}
