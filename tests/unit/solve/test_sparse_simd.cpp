// Each instruction set's sums of the sparse products, called by name (csr_kernels.hpp's Plain/Avx2/Avx512SparseSums,
// runs_kernels.hpp's Plain/Avx2/Avx512RunSums), so that an AVX-512 build also runs the AVX2 path that the GPU kit's
// x86-64-v3 build takes: every path against the float64 product of the stored values (tight: only the sums' order
// differs) and of the dense float32 F (the storage's value rounding), on rows made for the tails: empty rows, rows
// whose length is not a multiple of the vector width (1, 7, 8, 9, 15, 16, 17, 31, 33), runs that cross 16-float
// boundaries of x, runs longer than the kernels' one block (a file's), bridges of long gaps and merged gaps.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "radiosity/solve/host/csr_kernels.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

using namespace radiosity;

namespace {

constexpr size_t kN = 320;

// Row i's kept columns, one pattern a row: empty, one block of a tail length at an odd start, every third column,
// and random runs (1-20 long, gaps 0-12).
std::vector<float> tail_rows(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.1f, 1.0f);
  std::vector<float> F(kN * kN, 0.0f);
  const size_t lengths[] = {0, 1, 7, 8, 9, 15, 16, 17, 31, 33, 64, 100};
  for (size_t i = 0; i < kN; ++i) {
    float* row = F.data() + i * kN;
    const size_t kind = i % 16;
    if (kind < 12) {
      const size_t start = (13 * i) % 150;  // blocks that start anywhere in a 16-float line of x
      for (size_t q = 0; q < lengths[kind]; ++q) row[start + q] = u(rng) / kN;
    } else if (kind == 12) {
      for (size_t j = i % 3; j < kN; j += 3) row[j] = u(rng) / kN;
    } else {
      for (size_t j = rng() % 5; j < kN;) {
        const size_t len = 1 + rng() % 20;
        for (size_t q = 0; q < len && j < kN; ++q, ++j) row[j] = u(rng) / kN;
        j += rng() % 13;
      }
    }
  }
  return F;
}

struct Operands {
  Aos<float> x{kN}, y{kN}, rho{kN}, e{kN};
  float a = 0.25f, c = 0.9f, d = 1.5f;
  explicit Operands(unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (size_t i = 0; i < kN; ++i)
      for (int ch = 0; ch < 3; ++ch) x(i, ch) = u(rng), rho(i, ch) = 0.2f + 0.7f * u(rng), e(i, ch) = u(rng);
  }
  // a·x + c·ρ·s + d·e in double, s the row's sum of F_ij x_j (get(k, j): the entry's value)
  template <class Get>
  double at(size_t i, int ch, const std::vector<std::pair<size_t, size_t>>& entries, Get get) const {
    double s = 0;
    for (const auto& [k, j] : entries) s += get(k, j) * double(x(j, ch));
    return double(a) * x(i, ch) + double(c) * rho(i, ch) * s + double(d) * e(i, ch);
  }
};

std::vector<Rgb> reflective(size_t n) { return std::vector<Rgb>(n, Rgb{0.5, 0.5, 0.5}); }

// y against the float64 products: of the stored values (within 2e-6 of the row's scale) and of F itself (tol).
template <class Val>
void expect_answer(const FormFactorMatrix& m, const std::vector<float>& F, const Operands& o, double tol,
                   const std::string& what) {
  const FFMatrixView v = m.view();
  const auto* data = static_cast<const typename Val::stored*>(v.data);
  for (size_t i = 0; i < kN; ++i) {
    std::vector<std::pair<size_t, size_t>> entries;
    for_each_entry(v, i, [&](size_t k, size_t j) { entries.emplace_back(k, j); });
    for (int ch = 0; ch < 3; ++ch) {
      const double stored = o.at(i, ch, entries, [&](size_t k, size_t) { return v.scale * Val::get(data, k); });
      const double dense = o.at(i, ch, entries, [&](size_t, size_t j) { return double(F[i * kN + j]); });
      ASSERT_NEAR(o.y(i, ch), stored, 2e-6 * (1 + std::fabs(stored))) << what << " row " << i << " channel " << ch;
      ASSERT_NEAR(o.y(i, ch), dense, tol * (1 + std::fabs(dense))) << what << " row " << i << " channel " << ch;
    }
  }
}

FormFactorMatrix build(const std::vector<float>& F, FFStorage st, FFValues values, uint32_t max_step = kMaxStep,
                       uint32_t max_length = kRunMaxLength) {
  FFMatrixOptions opt;
  opt.storage = st;
  opt.values = values;
  opt.max_step = max_step;
  opt.max_length = max_length;
  return FormFactorMatrix(F.data(), kN, reflective(kN), opt);
}

// csr (int32 columns) and compressed (uint16 steps; max_step small: bridges) by the sums Sums.
template <class Sums, class Val>
void check_csr(FFValues values, double tol, const std::string& what) {
  const std::vector<float> F = tail_rows(5);
  for (FFStorage st : {FFStorage::csr, FFStorage::compressed})
    for (uint32_t max_step : {kMaxStep, 20u}) {
      const FormFactorMatrix m = build(F, st, values, max_step);
      const FFMatrixView v = m.view();
      Operands o(9);
      const auto* data = static_cast<const typename Val::stored*>(v.data);
      const float* x4 = gather_copy(o.x);
      const float c = float(o.c * v.scale);
      if (st == FFStorage::csr)
        sparse_rows<Val, Int32Cols, Aos<float>, Sums>(data, Int32Cols{v.col}, v.row_start, x4, o.x, o.y, o.rho, o.e,
                                                      o.a, c, o.d, 0, kN);
      else
        sparse_rows<Val, Step16Cols, Aos<float>, Sums>(data, Step16Cols{v.step}, v.row_start, x4, o.x, o.y, o.rho,
                                                       o.e, o.a, c, o.d, 0, kN);
      expect_answer<Val>(m, F, o, tol, what + " " + to_string(st) + " max_step " + std::to_string(max_step));
    }
}

// runs (capped at 16 values, and a file's longer runs of up to 40; max_step small: bridges) by the sums Sums.
template <class Sums, class Val>
void check_runs(FFValues values, double tol, const std::string& what) {
  const std::vector<float> F = tail_rows(6);
  for (uint32_t max_step : {kMaxStep, 20u})
    for (uint32_t max_length : {kRunMaxLength, 40u}) {
      const FormFactorMatrix m = build(F, FFStorage::runs, values, max_step, max_length);
      const FFMatrixView v = m.view();
      Operands o(10);
      const float* xc[3];
      channel_arrays(o.x, xc);
      runs_rows<Val, Aos<float>, Sums>(static_cast<const typename Val::stored*>(v.data), v.run, v.row_start,
                                       v.run_start, xc, o.x, o.y, o.rho, o.e, o.a, float(o.c * v.scale), o.d, 0, kN);
      expect_answer<Val>(m, F, o, tol, what + " runs max_step " + std::to_string(max_step) + " max_length " +
                                           std::to_string(max_length));
    }
}

// float32 values: only the sums' order differs from float64; float16: a value's rounding, 2^-11 relative.
constexpr double kFloat32Tol = 2e-6, kFloat16Tol = 1e-3;

template <template <class, int> class RunSumsT, class Sums>
void check_every_path(const std::string& what) {
  check_csr<Sums, Float32Values>(FFValues::float32, kFloat32Tol, what + " float32");
  check_csr<Sums, Float16Values>(FFValues::float16, kFloat16Tol, what + " float16");
  check_csr<Sums, BFloat16Values>(FFValues::bfloat16, 8e-3, what + " bfloat16");
  check_runs<RunSumsT<Float32Values, 3>, Float32Values>(FFValues::float32, kFloat32Tol, what + " float32");
  check_runs<RunSumsT<Float16Values, 3>, Float16Values>(FFValues::float16, kFloat16Tol, what + " float16");
  check_runs<RunSumsT<BFloat16Values, 3>, BFloat16Values>(FFValues::bfloat16, 8e-3, what + " bfloat16");
}

template <class Val, int C>
using PlainFloatRunSums = PlainRunSums<Val, float, C>;

}  // namespace

TEST(SparseSimd, PlainSumsGiveTheFloat64Answer) { check_every_path<PlainFloatRunSums, PlainSparseSums>("plain"); }

#ifdef HPCGI_AVX2_SUMS
TEST(SparseSimd, Avx2SumsGiveTheFloat64Answer) { check_every_path<Avx2RunSums, Avx2SparseSums>("avx2"); }
#else
TEST(SparseSimd, Avx2SumsGiveTheFloat64Answer) { GTEST_SKIP() << "built without AVX2, FMA and F16C"; }
#endif

#ifdef HPCGI_AVX512_SUMS
TEST(SparseSimd, Avx512SumsGiveTheFloat64Answer) { check_every_path<Avx512RunSums, Avx512SparseSums>("avx512"); }
#else
TEST(SparseSimd, Avx512SumsGiveTheFloat64Answer) { GTEST_SKIP() << "built without AVX-512"; }
#endif
