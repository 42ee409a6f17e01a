// The k-right-hand-side product over F's row blocks (row_blocks.hpp, row_block_kernels.hpp) against a reference it
// does not share its sums with: k single products of the same stored F (affine_matvec: dense, runs, csr and
// compressed kernels), for every storage, every stored precision, float and double vectors, rows of reflectivity 0,
// an empty row, n not a multiple of the 16 rows of a block, one and two groups of right-hand sides (k = 1..11), 1 and
// 2 threads (the same bits).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "radiosity/solve/host/exec.hpp"
#include "radiosity/solve/host/linalg.hpp"
#include "radiosity/solve/storage/row_blocks.hpp"
#include "tests/unit/relight/relight_test_util.hpp"

using namespace radiosity;
using radiosity::test::rel_diff;
using radiosity::test::uniform;

namespace {

// n×n F: each row alternates kept stretches of 1..40 columns and gaps of 1..20 zeros; row 5 is all zeros.
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

template <class T>
struct Vectors {
  std::vector<Soa<T>> X, Y, E;
  std::vector<std::vector<Rgb>> xh, eh;
};
template <class T>
Vectors<T> make_vectors(const OpenMPExec& ex, size_t n, size_t k, uint64_t seed) {
  Vectors<T> v;
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

struct Problem {
  size_t n;
  std::vector<float> F;
  std::vector<Rgb> rho;
  std::vector<size_t> dark;  // reflectivity 0: not held by the blocks (dense: left out by rows)
  std::vector<int32_t> rows;
};
Problem make_problem(size_t n, uint64_t seed) {
  Problem p{n, sparse_f(n, seed), std::vector<Rgb>(n), {0, 17, n / 2, n - 1}, {}};
  uint64_t r = seed + 1;
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) p.rho[i][c] = 0.3 + 0.6 * uniform(r);
  for (size_t i : p.dark) p.rho[i] = {0, 0, 0};
  p.rows = dense_rows_to_compute(p.rho);
  return p;
}

// The k-product over M's blocks against k single products over M, for vectors of T; with 1 and 2 threads.
template <class T>
void check(const Problem& p, const FormFactorMatrix& M, double tol, const std::string& what) {
  const size_t n = p.n;
  std::map<size_t, std::vector<std::vector<Rgb>>> one_thread;  // k: each right-hand side's y with 1 thread
  for (int threads : {1, 2}) {
    const OpenMPExec ex(threads);
    const RowBlockMatrix B(M.view(), p.rows, threads);
    Soa<T> rs(n);
    load(ex, rs, p.rho);
    for (size_t k : {1, 2, 3, 7, 8, 11}) {
      Vectors<T> v = make_vectors<T>(ex, n, k, 99 + k);
      multi_affine_matvec<OpenMPExec, T>(ex, B, v.X, v.Y, rs, v.E, T(0.5), T(0.9), T(1));
      for (size_t q = 0; q < k; ++q) {
        const std::string at = what + " threads=" + std::to_string(threads) + " k=" + std::to_string(k) +
                               " q=" + std::to_string(q);
        Soa<T> x(n), y(n), e(n);
        load(ex, x, v.xh[q]), load(ex, e, v.eh[q]);
        affine_matvec(ex, M.view(), p.rows, x, y, rs, e, T(0.5), T(0.9), T(1));
        std::vector<Rgb> single, got;
        store(ex, y, single);
        store(ex, v.Y[q], got);
        EXPECT_LT(rel_diff(got, single), tol) << at;
        if (threads == 1)
          one_thread[k].push_back(got);
        else  // a row's sums do not depend on the thread that takes its block
          EXPECT_EQ(rel_diff(got, one_thread[k][q]), 0.0) << at;
        for (size_t i : p.dark)  // a·x + d·e exactly on a row without reflection
          for (int c = 0; c < 3; ++c) EXPECT_EQ(got[i][c], double(T(T(0.5) * T(v.xh[q][i][c]) + T(v.eh[q][i][c]))))
                                        << at << " i=" << i;
      }
    }
  }
}

}  // namespace

// Every storage in float32: float vectors to float rounding, double vectors to double rounding.
TEST(RowBlockProduct, EqualsSingleProductsForEveryStorage) {
  const Problem p = make_problem(1237, 3);  // 77 blocks and 5 rows
  for (FFStorage st : {FFStorage::dense, FFStorage::runs, FFStorage::csr, FFStorage::compressed}) {
    FFMatrixOptions opt;
    opt.storage = st;
    const FormFactorMatrix M(p.F.data(), p.n, p.rho, opt);
    check<float>(p, M, 1e-6, std::string(to_string(st)) + " float");
    check<double>(p, M, 1e-13, std::string(to_string(st)) + " double");
  }
}

// 16-bit values: the stored bits and F's scale (float16 is scaled by 2^k) reach the product as the solvers read them.
TEST(RowBlockProduct, SixteenBitValuesAndTheirScale) {
  const Problem p = make_problem(300, 5);
  for (FFValues values : {FFValues::float16, FFValues::bfloat16}) {
    FFMatrixOptions opt;
    opt.storage = FFStorage::runs;
    opt.values = values;
    const FormFactorMatrix M(p.F.data(), p.n, p.rho, opt);
    if (values == FFValues::float16) {
      ASSERT_LT(M.view().scale, 1.0);  // scaled: the test sees whether the scale is undone
    }
    check<float>(p, M, 1e-6, to_string(values));
    check<double>(p, M, 1e-13, std::string(to_string(values)) + " double");
  }
}

// The blocks hold every non-zero value once and nothing of the rows left out; their columns are those of a block
// where some row holds a value.
TEST(RowBlockProduct, BlocksHoldEveryValueAndOnlyTheNeededColumns) {
  const Problem p = make_problem(100, 7);
  const FormFactorMatrix dense(p.F.data(), p.n, p.rho, FFMatrixOptions{});
  const RowBlockMatrix B(dense.view(), p.rows, 2);
  size_t nonzero = 0, columns = 0;
  for (size_t b = 0; b * kBlockRows < p.n; ++b) {
    std::vector<char> any(p.n, 0);
    for (size_t i = b * kBlockRows; i < std::min(p.n, (b + 1) * kBlockRows); ++i) {
      if (p.rho[i][0] == 0) continue;
      for (size_t j = 0; j < p.n; ++j)
        if (p.F[i * p.n + j] != 0) any[j] = 1, ++nonzero;
    }
    for (char a : any) columns += size_t(a);
  }
  EXPECT_EQ(B.blocks(), 7u);
  EXPECT_EQ(B.nonzeros(), nonzero);
  EXPECT_EQ(B.columns(), columns);
  EXPECT_GT(B.bytes(), double(columns * kBlockRows * 4));
}

// No patches: nothing to do, nothing read.
TEST(RowBlockProduct, EmptyMatrix) {
  const std::vector<float> F;
  const FormFactorMatrix M(F.data(), 0, {}, FFMatrixOptions{});
  const RowBlockMatrix B(M.view(), {}, 1);
  EXPECT_EQ(B.blocks(), 0u);
  EXPECT_EQ(B.columns(), 0u);
  std::vector<Soa<float>> X, Y, E;
  X.emplace_back(0), Y.emplace_back(0), E.emplace_back(0);
  const Soa<float> rho(0);
  multi_affine_matvec<OpenMPExec, float>(OpenMPExec(1), B, X, Y, rho, E, 0.0f, 1.0f, 1.0f);
}
