// The load (solve_load.cpp): the mesh, the form factors in the one FormFactorMatrix, the run's matrix, the memory;
// its steps return a Loaded, and the error reference is a phase of its own between its steps (solve_verify.hpp).
#include <string>
#include <utility>

#include "common/errors.hpp"
#include "radiosity/app/solve_load.hpp"
#include "radiosity/app/solve_verify.hpp"
#include "tests/unit/app/solve_fixture.hpp"

using namespace radiosity;
using namespace radiosity::app;
using solve_phases::SolvePhases;

TEST_F(SolvePhases, LoadsTheDenseFileAsItIs) {
  const Loaded L = load_solve(plan_solve(args));
  EXPECT_EQ(L.n, 4u);
  EXPECT_EQ(L.patches, "4 patches");
  EXPECT_FALSE(L.sparse_file);
  ASSERT_NE(L.matrix, nullptr);  // the one matrix: the file's values, every row, dense float32
  EXPECT_EQ(L.matrix->rows(), 4u);
  EXPECT_EQ(L.matrix->view().storage, FFStorage::dense);
  EXPECT_EQ(L.sys.matrix.data, L.matrix->view().data);
  EXPECT_NE(dense_float32(L.sys), nullptr);
  EXPECT_EQ(L.params.resolution, 32);
  EXPECT_TRUE(L.same_matrix);  // float32, nothing dropped: the reference is solved after the run, on this matrix
  EXPECT_EQ(L.skipped_rows, 2u);  // the emitting squares reflect nothing
  EXPECT_EQ(L.matrix_storage_bytes, 4.0 * 16);
}

TEST_F(SolvePhases, RoundedValuesTakeTheirReferenceBeforeRounding) {
  args.storage = "dense";
  args.ff_precision = "float16";
  const SolvePlan p = plan_solve(args);
  Loaded L = load_mesh(p);
  References R;
  solve_reference_at(ReferencePoint::before_form_factors, p, L, R);
  EXPECT_FALSE(R.have);  // no --reference-ff
  L = read_form_factors(p, std::move(L));
  EXPECT_FALSE(L.same_matrix);
  EXPECT_NE(dense_float32(L.sys), nullptr);  // the file's values, not yet rounded
  solve_reference_at(ReferencePoint::before_rounding, p, L, R);
  ASSERT_TRUE(R.have);
  EXPECT_TRUE(R.ref.converged);
  EXPECT_EQ(R.ref.B.size(), 4u);
  L = build_matrix(p, std::move(L));
  EXPECT_EQ(L.storage, FFStorage::dense);
  ASSERT_NE(L.matrix, nullptr);
  EXPECT_EQ(dense_float32(L.sys), nullptr);  // the run's matrix replaced the file's dense values
  EXPECT_EQ(L.sys.matrix.values, FFValues::float16);
  EXPECT_EQ(L.matrix->dense_float32_values(), nullptr);
}

TEST_F(SolvePhases, TheFileMatrixTakesItsReferenceAfterTheRun) {
  const SolvePlan p = plan_solve(args);
  const Loaded L = read_form_factors(p, load_mesh(p));
  References R;
  solve_reference_at(ReferencePoint::before_rounding, p, L, R);
  EXPECT_FALSE(R.have);  // same_matrix: it waits for the run
  solve_reference_at(ReferencePoint::after_run, p, L, R);
  EXPECT_TRUE(R.have);
}

TEST_F(SolvePhases, NoReferenceWithoutVerify) {
  args.storage = "csr";
  args.ff_precision = "float16";
  args.verify = false;
  const SolvePlan p = plan_solve(args);
  Loaded L = read_form_factors(p, load_mesh(p));
  References R;
  solve_reference_at(ReferencePoint::before_rounding, p, L, R);
  L = build_matrix(p, std::move(L));
  EXPECT_EQ(L.storage, FFStorage::csr);
  EXPECT_FALSE(R.have);
}

TEST_F(SolvePhases, MemoryLimitRefusesBeforeLoading) {
  args.max_memory_per_rank = "1K";
  const SolvePlan p = plan_solve(args);
  Loaded L = load_mesh(p);
  EXPECT_THROW(read_form_factors(p, std::move(L)), hpcgi::UsageError);
}
