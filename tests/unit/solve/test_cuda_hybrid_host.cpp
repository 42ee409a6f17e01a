// The CPU's rows of backend hybrid (hybrid_host.cpp), which need no GPU and run everywhere: from row 0 they are
// backend openmp bit for bit (what makes hybrid with d = 0 the openmp result exactly); from a later row they are
// the same rows of openmp's product and leave the rows before alone.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "radiosity/solve/contract/backends.hpp"
#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/gpu/hybrid_host.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

std::vector<Rgb> random_vector(size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Rgb> v(n);
  for (Rgb& x : v)
    for (double& c : x) c = u(rng);
  return v;
}

// The rows [first, n) of slot v (zero before first).
template <class T>
std::vector<Rgb> rows_of(const HostRows<T>& h, int v, size_t n) {
  std::vector<Rgb> x(n, Rgb{0, 0, 0});
  h.store(v, x);
  return x;
}

// Every row of slot v as the part holds it.
template <class T>
std::vector<Rgb> all_of(HostRows<T>& h, int v, size_t n) {
  std::vector<Rgb> x(n);
  const T* d = h.data(v);
  for (size_t i = 0; i < n; ++i)
    for (int ch = 0; ch < 3; ++ch) x[i][ch] = d[3 * i + ch];
  return x;
}

template <class T>
void from_row_zero_is_openmp(size_t n, int threads) {
  SCOPED_TRACE("n " + std::to_string(n) + " threads " + std::to_string(threads) + (sizeof(T) == 4 ? " float" : " double"));
  const Problem p = random_problem(n, 71);
  SolveConfig c;
  c.backend = "openmp";
  c.layout = Layout::aos;
  c.precision = sizeof(T) == 4 ? Precision::single : Precision::double_;
  c.steps = 32;
  c.threads = threads;
  const SolveResult omp = solve(p.sys, c);

  HostRows<T> h(p.sys, 0, 2, threads);
  EXPECT_EQ(h.threads(), threads);
  h.load(0, p.sys.initial);
  int cur = 0, nxt = 1;
  for (int step = 0; step < 32; ++step) {
    h.matvec(nxt, cur, 0, 1, 1);
    std::swap(cur, nxt);
  }
  EXPECT_EQ(rows_of(h, cur, n), omp.B);

  // The reductions too: the same blocks, the same partial sums, added in the same order.
  const auto k = make_openmp<T>(p.sys, c, 2);
  const std::vector<Rgb> x = random_vector(n, 1), y = random_vector(n, 2);
  k->upload(0, x);
  k->upload(1, y);
  h.load(0, x);
  h.load(1, y);
  EXPECT_EQ(h.dot(0, 1), k->dot(0, 1));
  EXPECT_EQ(h.dist2(0, 1), k->dist2(0, 1));
}

template <class T>
void later_rows_are_openmp_rows(size_t first) {
  const double tol = sizeof(T) == 4 ? 1e-6 : 1e-14;
  SCOPED_TRACE("first " + std::to_string(first) + (sizeof(T) == 4 ? " float" : " double"));
  const size_t n = 203;
  const Problem p = random_problem(n, 73);
  SolveConfig c;
  c.layout = Layout::aos;
  c.threads = 3;
  const auto k = make_openmp<T>(p.sys, c, 3);
  HostRows<T> h(p.sys, first, 3, 3);
  const std::vector<Rgb> x = random_vector(n, 3), y = random_vector(n, 4);
  for (int v : {0, 1}) {
    k->upload(v, v == 0 ? x : y);
    h.load(v, v == 0 ? x : y);
  }
  auto expect_rows = [&](const std::vector<Rgb>& got, const std::vector<Rgb>& want, const std::vector<Rgb>& before) {
    for (size_t i = 0; i < n; ++i)
      for (int ch = 0; ch < 3; ++ch) {
        if (i < first)
          EXPECT_EQ(got[i][ch], before[i][ch]) << "row " << i << " is not this part's";
        else
          EXPECT_NEAR(got[i][ch], want[i][ch], tol * (1 + std::abs(want[i][ch]))) << "row " << i;
      }
  };
  std::vector<Rgb> want, before = all_of(h, 2, n);
  k->matvec(2, 0, 0.5, -0.7, 1.3);
  h.matvec(2, 0, T(0.5), T(-0.7), T(1.3));
  k->download(2, want);
  expect_rows(all_of(h, 2, n), want, before);
  EXPECT_EQ(rows_of(h, 2, n)[n - 1], all_of(h, 2, n)[n - 1]);

  const Rgb a{0.25, -1.5, 2}, b{1, 0.5, -0.75};
  before = all_of(h, 1, n);
  k->axpby(1, a, 0, b);
  h.axpby(1, a, 0, b);
  k->download(1, want);
  expect_rows(all_of(h, 1, n), want, before);
  before = all_of(h, 2, n);
  k->copy(2, 0);
  h.copy(2, 0);
  k->download(2, want);
  expect_rows(all_of(h, 2, n), want, before);

  // Σ over rows [first, n) only, against a plain sum in double of what the part holds.
  const std::vector<Rgb> hx = rows_of(h, 0, n), hy = rows_of(h, 1, n);
  Rgb dot{0, 0, 0}, d2{0, 0, 0};
  for (size_t i = first; i < n; ++i)
    for (int ch = 0; ch < 3; ++ch) {
      dot[ch] += hx[i][ch] * hy[i][ch];
      d2[ch] += (hx[i][ch] - hy[i][ch]) * (hx[i][ch] - hy[i][ch]);
    }
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_NEAR(h.dot(0, 1)[ch], dot[ch], 1e-12 * n);
    EXPECT_NEAR(h.dist2(0, 1)[ch], d2[ch], 1e-12 * n);
  }
}

}  // namespace

TEST(CudaHybridHost, FromRowZeroItIsTheOpenmpBackendBitForBit) {
  for (size_t n : {203, 40})
    for (int threads : {1, 3}) {
      from_row_zero_is_openmp<float>(n, threads);
      from_row_zero_is_openmp<double>(n, threads);
    }
}

TEST(CudaHybridHost, FromALaterRowItComputesThoseRowsOnly) {
  for (size_t first : {70, 71, 202}) {
    later_rows_are_openmp_rows<float>(first);
    later_rows_are_openmp_rows<double>(first);
  }
}

TEST(CudaHybridHost, WithNoRowsItComputesNothing) {
  const size_t n = 40;
  const Problem p = random_problem(n, 79);
  HostRows<float> h(p.sys, n, 2, 2);
  h.load(0, p.sys.initial);
  h.matvec(1, 0, 0, 1, 1);
  EXPECT_EQ(rows_of(h, 1, n), std::vector<Rgb>(n, Rgb{0, 0, 0}));
  EXPECT_EQ(h.dot(0, 0), (Rgb{0, 0, 0}));
}

// The split of backend hybrid: ⌈d n⌉ rows on the GPU, checked against the exact integer ceiling ⌈k n / 10⌉ for the
// decimal distributions of Table 4.5 (whose binary values put some d·n a hair above an integer), and at least one
// row for any d > 0, however small d·n is (it gave 0 rows for 0 < d·n <= 1e-9).
TEST(CudaHybridHost, GpuRowsAreTheCeilingOfDTimesN) {
  for (size_t n = 0; n <= 300; ++n)
    for (size_t k = 0; k <= 10; ++k) EXPECT_EQ(gpu_rows(n, double(k) / 10), (k * n + 9) / 10) << "n=" << n << " k=" << k;
  EXPECT_EQ(gpu_rows(17128, 0.1), 1713u);
  EXPECT_EQ(gpu_rows(100, 1e-12), 1u);  // d·n = 1e-10
  EXPECT_EQ(gpu_rows(1, 5e-10), 1u);
  EXPECT_EQ(gpu_rows(100, 0.0), 0u);
  EXPECT_EQ(gpu_rows(100, 1.0), 100u);
}
