// The k-right-hand-side product over sparse storages (multi_runs_kernels.hpp) against references it does not share
// its sums with: k single products of the same storage (affine_matvec: runs_rows, sparse_rows) and the dense
// k-product (linalg.hpp's multi_matvec_rows), with rows of reflectivity 0 (empty in the sparse storages), an empty
// row, runs of every length from 1 to 40 cut where the column chunks end, every column width (k = 2, 3, 8) and two
// groups of right-hand sides (k = 11), 1 and 2 threads (the same bits).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "radiosity/solve/cpu/exec.hpp"
#include "tests/unit/relight/relight_test_util.hpp"
#include "radiosity/solve/cpu/linalg.hpp"
#include "radiosity/solve/cpu/multi_runs_kernels.hpp"

using namespace radiosity;
using radiosity::test::rel_diff;
using radiosity::test::uniform;

namespace {

// n×n F of runs: each row alternates kept stretches of 1..40 columns and gaps of 1..20 zeros (some merged into runs
// by kRunMergeGap, some not); row 5 is all zeros.
std::vector<float> sparse_f(size_t n, uint64_t seed) {
  std::vector<float> F(n * n, 0.0f);
  uint64_t r = seed;
  for (size_t i = 0; i < n; ++i) {
    if (i == 5) continue;
    for (size_t j = size_t(20 * uniform(r)); j < n;) {
      const size_t len = 1 + size_t(40 * uniform(r));
      for (size_t q = j; q < std::min(n, j + len); ++q) F[i * n + q] = float(1e-3 * (0.1 + uniform(r)));
      j += len + 1 + size_t(20 * uniform(r));
    }
  }
  return F;
}

struct Vectors {
  std::vector<Soa<float>> X, Y, E;
  std::vector<std::vector<Rgb>> xh, eh;
};
Vectors make_vectors(const OpenMPExec& ex, size_t n, size_t k, uint64_t seed) {
  Vectors v;
  uint64_t r = seed;
  v.xh.resize(k), v.eh.resize(k);
  for (size_t q = 0; q < k; ++q) {
    v.xh[q].resize(n), v.eh[q].resize(n);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) v.xh[q][i][c] = uniform(r), v.eh[q][i][c] = uniform(r);
    v.X.emplace_back(n), v.Y.emplace_back(n), v.E.emplace_back(n);
    load(ex, v.X.back(), v.xh[q]), load(ex, v.E.back(), v.eh[q]);
  }
  return v;
}

}  // namespace

TEST(MultiSparseProduct, EqualsSingleProductsAndTheDenseKProduct) {
  const size_t n = 1237;  // not a multiple of a block, the group or the row alignment
  const std::vector<float> F = sparse_f(n, 3);
  uint64_t r = 17;
  std::vector<Rgb> rho(n);
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) rho[i][c] = 0.3 + 0.6 * uniform(r);
  const std::vector<size_t> dark = {0, 17, 800, n - 1};  // reflectivity 0: empty rows in the sparse storages
  for (size_t i : dark) rho[i] = {0, 0, 0};
  const std::vector<int32_t> rows = dense_rows_to_compute(rho);
  ASSERT_EQ(rows.size(), n - dark.size());
  const FormFactorMatrix dense(F.data(), n, rho, FFMatrixOptions{});
  for (FFStorage st : {FFStorage::runs, FFStorage::csr, FFStorage::compressed}) {
    FFMatrixOptions opt;
    opt.storage = st;
    const FormFactorMatrix M(F.data(), n, rho, opt);
    if (st == FFStorage::runs) {
      ASSERT_GT(M.runs().runs, 4 * n);  // many runs a row, not one
    }
    std::map<size_t, std::vector<std::vector<Rgb>>> one_thread;  // k: each right-hand side's y with 1 thread
    for (int threads : {1, 2}) {
      const OpenMPExec ex(threads);
      Soa<float> rs(n);
      load(ex, rs, rho);
      for (size_t k : {1, 2, 3, 8, 11}) {
        Vectors v = make_vectors(ex, n, k, 99 + k);
        Vectors w = make_vectors(ex, n, k, 99 + k);  // the same values: the dense k-product's
        multi_affine_matvec<OpenMPExec, float>(ex, M.view(), rows, v.X, v.Y, rs, v.E, 0.5f, 0.9f, 1.0f);
        multi_affine_matvec<OpenMPExec, float>(ex, dense.view(), rows, w.X, w.Y, rs, w.E, 0.5f, 0.9f, 1.0f);
        for (size_t q = 0; q < k; ++q) {
          const std::string at = std::string(to_string(st)) + " threads=" + std::to_string(threads) +
                                 " k=" + std::to_string(k) + " q=" + std::to_string(q);
          Aos<float> x(n), y(n), e(n), ra(n);
          load(ex, x, v.xh[q]), load(ex, e, v.eh[q]), load(ex, ra, rho);
          affine_matvec(ex, M.view(), rows, x, y, ra, e, 0.5f, 0.9f, 1.0f);
          std::vector<Rgb> single, got, from_dense;
          store(ex, y, single);
          store(ex, v.Y[q], got);
          store(ex, w.Y[q], from_dense);
          EXPECT_LT(rel_diff(got, single), 1e-6) << at;
          if (threads == 1)
            one_thread[k].push_back(got);
          else  // a row's sums do not depend on the rows beside it or the thread that takes it
            EXPECT_EQ(rel_diff(got, one_thread[k][q]), 0.0) << at;
          EXPECT_LT(rel_diff(got, from_dense), 1e-6) << at;
          if (st == FFStorage::runs && k == 1) {
            EXPECT_EQ(rel_diff(got, single), 0.0) << at;  // runs_rows itself
          }
          for (size_t i : dark)  // a·x + d·e exactly on a row without reflection
            for (int c = 0; c < 3; ++c)
              EXPECT_EQ(got[i][c], float(0.5f * float(v.xh[q][i][c]) + float(v.eh[q][i][c]))) << at << " i=" << i;
        }
      }
    }
  }
}

// float16 runs: the scale folded into c as the dense path does; the k-product equals k single products of the same
// stored values, and a double k-product (the light basis's element type, the plain path) agrees too.
TEST(MultiSparseProduct, Float16RunsAndDoubleVectors) {
  const size_t n = 700;
  const std::vector<float> F = sparse_f(n, 5);
  std::vector<Rgb> rho(n, Rgb{0.7, 0.5, 0.3});
  rho[3] = {0, 0, 0};
  FFMatrixOptions opt;
  opt.storage = FFStorage::runs;
  opt.values = FFValues::float16;
  const FormFactorMatrix M(F.data(), n, rho, opt);
  ASSERT_LT(M.view().scale, 1.0);  // scaled: the test sees whether the scale is undone
  const OpenMPExec ex(2);
  Soa<float> rs(n);
  load(ex, rs, rho);
  Soa<double> rd(n);
  load(ex, rd, rho);
  const size_t k = 9;
  Vectors v = make_vectors(ex, n, k, 5);
  multi_affine_matvec<OpenMPExec, float>(ex, M.view(), {}, v.X, v.Y, rs, v.E, 0.0f, 1.0f, 1.0f);
  std::vector<Soa<double>> Xd, Yd, Ed;
  for (size_t q = 0; q < k; ++q) {
    Xd.emplace_back(n), Yd.emplace_back(n), Ed.emplace_back(n);
    load(ex, Xd.back(), v.xh[q]), load(ex, Ed.back(), v.eh[q]);
  }
  multi_affine_matvec<OpenMPExec, double>(ex, M.view(), {}, Xd, Yd, rd, Ed, 0.0, 1.0, 1.0);
  for (size_t q = 0; q < k; ++q) {
    Aos<float> x(n), y(n), e(n), ra(n);
    load(ex, x, v.xh[q]), load(ex, e, v.eh[q]), load(ex, ra, rho);
    affine_matvec(ex, M.view(), {}, x, y, ra, e, 0.0f, 1.0f, 1.0f);
    std::vector<Rgb> single, got, got_d;
    store(ex, y, single);
    store(ex, v.Y[q], got);
    store(ex, Yd[q], got_d);
    EXPECT_LT(rel_diff(got, single), 1e-6) << "q=" << q;
    EXPECT_LT(rel_diff(got_d, single), 1e-6) << "q=" << q;
  }
}
