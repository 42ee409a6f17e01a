// The form factors in other storage (ff_matrix.hpp): CSR against dense, 16-bit values, thresholds, the rows of
// patches with reflectivity 0 left out, and who refuses what.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "common/errors.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/storage/half.hpp"
#include "radiosity/solve/solve.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

// random_problem with about `zero_share` of F set to 0 (occlusion), rows rescaled to keep ρF's norms below 1.
Problem sparse_problem(size_t n, unsigned seed, double zero_share) {
  Problem p = random_problem(n, seed);
  std::mt19937_64 rng(seed + 1);
  std::uniform_real_distribution<double> u(0, 1);
  for (float& f : p.F)
    if (u(rng) < zero_share) f = 0;
  return p;
}

SolveConfig config(const std::string& backend, const std::string& layout, const std::string& method,
                   const std::string& precision, long steps) {
  return solve_config(backend, layout, method, precision, steps);
}

// The same system with its F held as `opt` says (the matrix must outlive the system).
System stored_as(const Problem& p, const FormFactorMatrix& m) {
  System s = p.sys;
  s.matrix = m.view();
  return s;
}

FFMatrixOptions options(FFStorage storage, FFValues values, double threshold = 0) {
  FFMatrixOptions o;
  o.storage = storage;
  o.values = values;
  o.threshold = threshold;
  return o;
}

}  // namespace

// The check: at threshold 0, CSR holds exactly the non-zero F_ij, and every method, layout, precision and
// CPU backend gives the dense answer within 1e-6 relative (the sums only run in another order).
TEST(Storage, CsrAndDenseAgreeAtThresholdZero) {
  const Problem p = sparse_problem(203, 51, 0.7);
  const FormFactorMatrix csr(p.F.data(), p.sys.n, p.sys.reflectivity, options(FFStorage::csr, FFValues::float32));
  size_t nonzero = 0;
  for (float f : p.F) nonzero += f != 0;
  EXPECT_EQ(csr.kept(), nonzero);
  EXPECT_DOUBLE_EQ(csr.bytes(), 8.0 * double(nonzero) + 8.0 * 204);
  const System s = stored_as(p, csr);
  for (const char* backend : {"serial", "openmp"})
    for (const char* layout : {"aos", "soa"})
      for (const char* precision : {"float", "double"})
        for (const auto& [method, steps] : {std::pair{"jacobi", 32L}, {"jacobi", 0L}, {"bicgstab", 0L}}) {
          SCOPED_TRACE(std::string(backend) + " " + layout + " " + precision + " " + method + " " +
                       std::to_string(steps));
          expect_storage_agrees(p.sys, s, config(backend, layout, method, precision, steps), csr.bytes());
        }
}

// CSR's rows are summed by one loop whatever the thread count: fixed steps give the same bits with any.
TEST(Storage, CsrIsBitIdenticalForAnyThreadCount) {
  const Problem p = sparse_problem(203, 53, 0.5);
  const FormFactorMatrix csr(p.F.data(), p.sys.n, p.sys.reflectivity, options(FFStorage::csr, FFValues::float32));
  const System s = stored_as(p, csr);
  const SolveResult serial = solve(s, config("serial", "aos", "jacobi", "float", 16));
  for (int threads : {2, 3, 5}) {
    SolveConfig c = config("openmp", "aos", "jacobi", "float", 16);
    c.threads = threads;
    EXPECT_EQ(solve(s, c).B, serial.B) << threads << " threads";
  }
}

// A threshold drops |F_ij| <= T: the same as the dense solve of F with those set to 0, in either storage.
TEST(Storage, ThresholdDropsTheSmallFormFactors) {
  Problem p = random_problem(150, 57);
  std::vector<float> sorted(p.F);
  std::sort(sorted.begin(), sorted.end());
  const double T = sorted[sorted.size() / 2];  // a value that is present: "at" the threshold is dropped too
  const FormFactorMatrix csr(p.F.data(), p.sys.n, p.sys.reflectivity, options(FFStorage::csr, FFValues::float32, T));
  const FormFactorMatrix dense(p.F.data(), p.sys.n, p.sys.reflectivity,
                               options(FFStorage::dense, FFValues::float32, T));
  const SolveConfig c = config("serial", "aos", "jacobi", "double", 32);
  const SolveResult from_csr = solve(stored_as(p, csr), c), from_dense = solve(stored_as(p, dense), c);
  const size_t kept_by_count = count_kept(p.F.data(), p.sys.n, p.sys.reflectivity, T);
  EXPECT_EQ(apply_threshold(p.F.data(), p.sys.n, T), kept_by_count);
  EXPECT_EQ(csr.kept(), kept_by_count);
  EXPECT_LT(csr.kept(), p.F.size() / 2 + 1);
  const SolveResult zeroed = solve(p.sys, c);
  EXPECT_LE(rel_diff(from_csr.B, zeroed.B), 1e-12);
  EXPECT_EQ(from_dense.B, zeroed.B);
}

// 16-bit values: round to nearest-even once, widen exactly; float16 keeps the small form factors of a large
// scene normal by its power-of-two scale.
TEST(Storage, HalfAndBfloat16Rounding) {
  for (float f : {0.0f, 1.0f, 0.5f, 65504.0f, 0x1p-14f, 0x1p-24f, 3.0f * 0x1p-20f, -2.0f})
    EXPECT_EQ(half_to_float(float_to_half(f)), f) << f;  // representable: exact
  EXPECT_EQ(half_to_float(float_to_half(1.0f + 0x1p-11f)), 1.0f);                  // tie to even (down)
  EXPECT_EQ(half_to_float(float_to_half(1.0f + 3 * 0x1p-11f)), 1.0f + 0x1p-9f);    // tie to even (up)
  EXPECT_EQ(half_to_float(float_to_half(0x1p-25f)), 0.0f);                         // half way to the least: even
  EXPECT_TRUE(std::isinf(half_to_float(float_to_half(1e6f))));
  EXPECT_TRUE(std::isnan(half_to_float(float_to_half(NAN))));
  for (float f : {0.0f, 1.0f, 0x1p-100f, 0x1p127f, -0.375f}) EXPECT_EQ(bfloat16_to_float(float_to_bfloat16(f)), f) << f;
  EXPECT_EQ(bfloat16_to_float(float_to_bfloat16(1.0f + 0x1p-8f)), 1.0f);  // tie to even
  EXPECT_TRUE(std::isnan(bfloat16_to_float(float_to_bfloat16(NAN))));
  // 1.2345e-6 is below half's normal range (6.1e-5): scaled by 2^16, which takes the largest value 0.75 to
  // 49152 (below 65504), it keeps 11 bits.
  std::vector<float> F(4, 0.0f);
  F[1] = 1.2345e-6f;
  F[2] = 0.75f;
  const std::vector<Rgb> rho(2, Rgb{0.5, 0.5, 0.5});
  const FormFactorMatrix h(F.data(), 2, rho, options(FFStorage::dense, FFValues::float16));
  const FFMatrixView v = h.view();
  const auto* bits = static_cast<const uint16_t*>(v.data);
  EXPECT_EQ(v.scale, 0x1p-16);
  EXPECT_NEAR(half_to_float(bits[1]) * v.scale, 1.2345e-6, 1.2345e-6 * 0x1p-11);
  EXPECT_EQ(half_to_float(bits[2]) * v.scale, 0.75);
}

// F stored in 16 bits, summed in the working precision: the answer moves by about the values' rounding.
TEST(Storage, SixteenBitFormFactorsCostTheirRounding) {
  const Problem p = sparse_problem(200, 59, 0.3);
  const SolveConfig c = config("openmp", "aos", "jacobi", "double", 0);
  const SolveResult exact = solve(p.sys, c);
  for (FFStorage storage : {FFStorage::dense, FFStorage::csr})
    for (const auto& [values, unit] : {std::pair{FFValues::float16, 0x1p-11}, {FFValues::bfloat16, 0x1p-8}}) {
      SCOPED_TRACE(std::string(to_string(storage)) + " " + to_string(values));
      const FormFactorMatrix m(p.F.data(), p.sys.n, p.sys.reflectivity, options(storage, values));
      EXPECT_DOUBLE_EQ(m.bytes(), storage == FFStorage::dense ? 2.0 * 200 * 200 : 6.0 * double(m.kept()) + 8 * 201);
      const SolveResult r = solve(stored_as(p, m), c);
      ASSERT_EQ(r.status, SolveStatus::converged);
      const double d = rel_diff(r.B, exact.B);
      EXPECT_GT(d, 0);
      EXPECT_LE(d, 10 * unit);  // each F_ij within half a unit; ρF's norm below 0.9 amplifies by at most 10
    }
}

// The dense product widens 16-bit values exactly (eight at a time with F16C where the CPU has it, one by one in the
// last columns of a row): F in float16 or bfloat16 gives, bit for bit, the answer of float32 storage holding the
// same values widened (float16's power-of-two scale commutes with the rounding). n = 203 leaves a tail of 3
// columns and 3 rows outside the groups of four; AOS and SOA run the same loop, so they agree bit for bit too.
TEST(Storage, SixteenBitValuesAreWidenedExactly) {
  const Problem p = sparse_problem(203, 67, 0.2);
  for (FFValues values : {FFValues::float16, FFValues::bfloat16}) {
    SCOPED_TRACE(to_string(values));
    const FormFactorMatrix m16(p.F.data(), p.sys.n, p.sys.reflectivity, options(FFStorage::dense, values));
    const FFMatrixView v = m16.view();
    const auto* bits = static_cast<const uint16_t*>(v.data);
    std::vector<float> widened(p.F.size());
    for (size_t k = 0; k < widened.size(); ++k)
      widened[k] = float((values == FFValues::float16 ? half_to_float(bits[k]) : bfloat16_to_float(bits[k])) * v.scale);
    const FormFactorMatrix m32(widened.data(), p.sys.n, p.sys.reflectivity,
                               options(FFStorage::dense, FFValues::float32));
    const SolveResult want = solve(stored_as(p, m32), config("openmp", "soa", "jacobi", "float", 32));
    for (const char* layout : {"aos", "soa"})
      EXPECT_EQ(solve(stored_as(p, m16), config("openmp", layout, "jacobi", "float", 32)).B, want.B) << layout;
    EXPECT_EQ(solve(stored_as(p, m32), config("openmp", "aos", "jacobi", "float", 32)).B, want.B);
  }
}

// A patch with reflectivity 0 takes nothing from F: B_i = E_i. Its row is skipped (dense) or left empty (CSR),
// and the answer is the direct solve's.
TEST(Storage, RowsOfPatchesWithReflectivityZeroAreSkipped) {
  Problem p = random_problem(101, 61);
  for (size_t i = 0; i < p.sys.n; i += 3) p.sys.reflectivity[i] = {0, 0, 0};
  const std::vector<int32_t> rows = dense_rows_to_compute(p.sys.reflectivity);
  EXPECT_EQ(rows.size(), 101 - 34u);
  const std::vector<Rgb> exact = direct_solve(p.sys);
  const FormFactorMatrix csr(p.F.data(), p.sys.n, p.sys.reflectivity, options(FFStorage::csr, FFValues::float32));
  EXPECT_EQ(csr.kept(), count_kept(p.F.data(), p.sys.n, p.sys.reflectivity, 0));
  EXPECT_LE(csr.kept(), 67u * 101u);
  for (const auto& [name, sys] : {std::pair{"dense", p.sys}, {"csr", stored_as(p, csr)}})
    for (const char* method : {"jacobi", "bicgstab"}) {
      SCOPED_TRACE(std::string(name) + " " + method);
      const SolveResult r = solve(sys, config("openmp", "soa", method, "double", 0));
      EXPECT_LE(rel_diff(r.B, exact), 1e-10);
      if (std::string(method) == "jacobi") {  // each step sets them to E (BiCG-STAB's Krylov iterates come near)
        for (size_t i = 0; i < p.sys.n; i += 3) EXPECT_EQ(r.B[i], p.sys.emission[i]);
      }
      if (std::string(name) == "dense") {
        EXPECT_EQ(r.matrix_bytes, 4.0 * 67 * 101);  // only the rows it computes
      }
    }
  // The pairs of rows are the same whatever the thread count: so are the bits.
  const SolveResult serial = solve(p.sys, config("serial", "aos", "jacobi", "float", 16));
  for (int threads : {2, 3, 5}) {
    SolveConfig c = config("openmp", "aos", "jacobi", "float", 16);
    c.threads = threads;
    EXPECT_EQ(solve(p.sys, c).B, serial.B) << threads << " threads";
  }
}

// The bytes each storage holds, and the names (what auto picks: test_sparse.cpp).
TEST(Storage, BytesAndNames) {
  EXPECT_DOUBLE_EQ(ff_storage_bytes(FFStorage::dense, FFValues::bfloat16, 10, 3), 200);
  EXPECT_DOUBLE_EQ(ff_storage_bytes(FFStorage::csr, FFValues::float32, 10, 3), 3 * 8 + 88);
  EXPECT_EQ(parse_ff_storage("csr"), FFStorage::csr);
  EXPECT_EQ(parse_ff_values("bfloat16"), FFValues::bfloat16);
  EXPECT_THROW(parse_ff_storage("coo"), hpcgi::UsageError);
  EXPECT_THROW(parse_ff_values("float8"), hpcgi::UsageError);
}

// Serial, openmp, mpi and (csr, compressed) cuda and cublas read another storage; the rest say so before they start.
TEST(Storage, BackendsThatReadDenseFloat32OnlyRefuseOtherStorage) {
  const Problem p = sparse_problem(40, 63, 0.5);
  const FormFactorMatrix csr(p.F.data(), p.sys.n, p.sys.reflectivity, options(FFStorage::csr, FFValues::float32));
  const System s = stored_as(p, csr);
  for (const char* backend : {"original", "hybrid"}) {
    SolveConfig c = config(backend, "aos", "jacobi", "float", 8);
    try {
      solve(s, c);
      ADD_FAILURE() << backend << " ran on CSR";
    } catch (const hpcgi::UsageError& e) {
      const std::string what = e.what();
      // A backend not built here says that first; a built one names the storage it cannot read.
      EXPECT_TRUE(what.find("does not read csr float32 form factors") != std::string::npos ||
                  what.find("is not available") != std::string::npos)
          << what;
    }
  }
}

// A threshold above every form factor keeps nothing (CSR holds no values at all): no light is exchanged, B = E.
TEST(Storage, CsrThatKeepsNothingGivesTheEmission) {
  const Problem p = random_problem(40, 65);
  const FormFactorMatrix none(p.F.data(), p.sys.n, p.sys.reflectivity, options(FFStorage::csr, FFValues::float32, 1.0));
  EXPECT_EQ(none.kept(), 0u);
  const SolveResult r = solve(stored_as(p, none), config("openmp", "aos", "jacobi", "double", 0));
  EXPECT_EQ(r.status, SolveStatus::converged);
  EXPECT_EQ(r.B, p.sys.emission);
}
