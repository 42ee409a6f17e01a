// The load (solve_load.cpp): the mesh, the form factors in the one FormFactorMatrix, the run's matrix, the memory.
#include <string>

#include "common/errors.hpp"
#include "radiosity/app/solve_load.hpp"
#include "tests/unit/app/solve_fixture.hpp"

using namespace radiosity;
using namespace radiosity::app;
using solve_phases::SolvePhases;

TEST_F(SolvePhases, LoadsTheDenseFileAsItIs) {
  LoadedSolve L;
  load_solve(args, plan_solve(args), L);
  EXPECT_EQ(L.n, 4u);
  EXPECT_EQ(L.patches, "4 patches");
  EXPECT_FALSE(L.sparse_file);
  ASSERT_NE(L.matrix, nullptr);  // the one matrix: the file's values, every row, dense float32
  EXPECT_EQ(L.matrix->rows(), 4u);
  EXPECT_EQ(L.matrix->view().storage, FFStorage::dense);
  EXPECT_EQ(L.sys.matrix.data, L.matrix->view().data);
  EXPECT_EQ(dense_float32(L.sys), L.matrix->dense_float32_values());
  EXPECT_EQ(L.params.resolution, 32);
  EXPECT_TRUE(L.same_matrix);  // float32, nothing dropped: the reference is solved after the run, on this matrix
  EXPECT_FALSE(L.have_ref);
  EXPECT_EQ(L.skipped_rows, 2u);  // the emitting squares reflect nothing
  EXPECT_EQ(L.matrix_storage_bytes, 4.0 * 16);
}

TEST_F(SolvePhases, RoundedValuesTakeTheirReferenceBeforeRounding) {
  args.storage = "dense";
  args.ff_precision = "float16";
  LoadedSolve L;
  load_solve(args, plan_solve(args), L);
  EXPECT_EQ(L.storage, FFStorage::dense);
  ASSERT_NE(L.matrix, nullptr);
  EXPECT_EQ(dense_float32(L.sys), nullptr);  // the run's matrix replaced the file's dense values
  EXPECT_EQ(L.sys.matrix.values, FFValues::float16);
  EXPECT_EQ(L.matrix->dense_float32_values(), nullptr);
  EXPECT_FALSE(L.same_matrix);
  ASSERT_TRUE(L.have_ref);
  EXPECT_TRUE(L.ref.converged);
  EXPECT_EQ(L.ref.B.size(), 4u);
}

TEST_F(SolvePhases, NoReferenceWithoutVerify) {
  args.storage = "csr";
  args.verify = false;
  LoadedSolve L;
  load_solve(args, plan_solve(args), L);
  EXPECT_EQ(L.storage, FFStorage::csr);
  EXPECT_FALSE(L.have_ref);
}

TEST_F(SolvePhases, MemoryLimitRefusesBeforeLoading) {
  args.max_memory_per_rank = "1K";
  LoadedSolve L;
  EXPECT_THROW(load_solve(args, plan_solve(args), L), hpcgi::UsageError);
  EXPECT_EQ(L.matrix, nullptr);  // nothing read
}
