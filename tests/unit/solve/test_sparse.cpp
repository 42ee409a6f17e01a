// The sparse products (csr_kernels.hpp, runs_kernels.hpp) against dense: the same answers, the same bits wherever
// the summation order is the same, 16-bit values within their rounding, and what --storage auto picks
// (storage_choice.hpp). How the storages hold F is test_sparse_structure.cpp's, their file test_sparse_file.cpp's.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <random>
#include <string>

#include "common/errors.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/scene/analytic.hpp"
#include "radiosity/solve/host/csr_kernels.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/formfactor/file/sparse.hpp"
#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/storage_choice.hpp"
#include "configs.hpp"
#include "reference.hpp"
#include "sparse_problems.hpp"

using namespace radiosity;
using namespace solve_test;
using namespace sparse_test;

// The check: every storage with float32 values gives the dense float32 answer within 1e-6 relative, on
// every CPU backend, layout, precision and method (n = 203: rows that end in a partial group of 8 entries).
TEST(Sparse, EveryStorageGivesTheDenseAnswer) {
  const Problem p = occluded_problem(203, 71, 0.8);
  for (FFStorage st : {FFStorage::csr, FFStorage::compressed, FFStorage::runs}) {
    const FormFactorMatrix m = stored(p, st, FFValues::float32);
    const System s = system_of(p, m);
    for (const char* backend : {"serial", "openmp"})
      for (const char* layout : {"aos", "soa"})
        for (const char* precision : {"float", "double"})
          for (const auto& [method, steps] : {std::pair{"jacobi", 32L}, {"jacobi", 0L}, {"bicgstab", 0L},
                                              {"gauss-seidel", 0L}}) {
            SCOPED_TRACE(std::string(to_string(st)) + " " + backend + " " + layout + " " + precision + " " + method +
                         " " + std::to_string(steps));
            expect_storage_agrees(p.sys, s, config(backend, layout, precision, steps, 2, method), m.bytes());
          }
  }
}

// A row's sum does not depend on the column code, the layout or the thread count: csr and compressed with the same
// values give the same bits, AOS and SOA too, serial and openmp with 1, 2, 3 or 5 threads too (32 fixed steps).
TEST(Sparse, SameSummationOrderGivesTheSameBits) {
  const Problem p = occluded_problem(203, 73, 0.7);
  for (FFValues v : {FFValues::float32, FFValues::float16, FFValues::bfloat16})
    for (const char* precision : {"float", "double"}) {
      SCOPED_TRACE(std::string(to_string(v)) + " " + precision);
      const FormFactorMatrix csr = stored(p, FFStorage::csr, v), comp = stored(p, FFStorage::compressed, v);
      const SolveResult want = solve(system_of(p, csr), config("serial", "aos", precision, 32, 1));
      for (const FormFactorMatrix* m : {&csr, &comp})
        for (const char* layout : {"aos", "soa"})
          for (int threads : {1, 2, 3, 5})
            EXPECT_EQ(solve(system_of(p, *m), config("openmp", layout, precision, 32, threads)).B, want.B)
                << to_string(m == &csr ? FFStorage::csr : FFStorage::compressed) << " " << layout << " " << threads;
    }
}

// 16-bit values cost their rounding and no more: compressed float16 is as close to dense float32 as dense float16
// is (the speed-accuracy table's float16 error), and bfloat16 as close as dense bfloat16.
TEST(Sparse, SixteenBitCompressedCostsTheRoundingOfItsValues) {
  const Problem p = occluded_problem(200, 75, 0.8);
  const SolveConfig c = config("openmp", "aos", "double", 0);
  const SolveResult exact = solve(p.sys, c);
  for (const auto& [v, unit] : {std::pair{FFValues::float16, 0x1p-11}, {FFValues::bfloat16, 0x1p-8}}) {
    SCOPED_TRACE(to_string(v));
    const FormFactorMatrix dense16 = stored(p, FFStorage::dense, v), comp = stored(p, FFStorage::compressed, v);
    const double d_dense = rel_diff(solve(system_of(p, dense16), c).B, exact.B);
    const double d_comp = rel_diff(solve(system_of(p, comp), c).B, exact.B);
    EXPECT_GT(d_comp, 0);
    EXPECT_LE(d_comp, 10 * unit);
    EXPECT_NEAR(d_comp, d_dense, 1e-9);  // the same rounded values; only the sums' order differs
    EXPECT_DOUBLE_EQ(comp.bytes(), 4.0 * double(comp.kept()) + 8 * 201);
    const FormFactorMatrix runs = stored(p, FFStorage::runs, v);
    const double d_runs = rel_diff(solve(system_of(p, runs), c).B, exact.B);
    EXPECT_GT(d_runs, 0);
    EXPECT_LE(d_runs, 10 * unit);
    EXPECT_NEAR(d_runs, d_dense, 1e-9);
    EXPECT_DOUBLE_EQ(runs.bytes(), 2.0 * double(runs.runs().entries) + 4.0 * double(runs.runs().runs) + 16 * 201);
  }
}

// The runs product's sum of a row depends on its runs only: AOS and SOA, serial and openmp with 1, 2 or 3 threads
// give the same bits, for every value type and working precision, grey scenes too (32 fixed steps).
TEST(Sparse, RunsGiveTheSameBitsOnEveryThreadCount) {
  const Problem p = occluded_problem(203, 81, 0.7);
  Problem grey = occluded_problem(203, 81, 0.7);  // the same F, every channel red's
  for (size_t i = 0; i < grey.sys.n; ++i) {
    grey.sys.reflectivity[i] = Rgb{p.sys.reflectivity[i][0], p.sys.reflectivity[i][0], p.sys.reflectivity[i][0]};
    grey.sys.emission[i] = Rgb{p.sys.emission[i][0], p.sys.emission[i][0], p.sys.emission[i][0]};
  }
  for (const Problem* q : {&p, static_cast<const Problem*>(&grey)})
    for (FFValues v : {FFValues::float32, FFValues::float16, FFValues::bfloat16})
      for (const char* precision : {"float", "double"}) {
        SCOPED_TRACE(std::string(to_string(v)) + " " + precision + (q == &grey ? " grey" : ""));
        const FormFactorMatrix m = stored(*q, FFStorage::runs, v);
        const SolveResult want = solve(system_of(*q, m), config("serial", "aos", precision, 32, 1));
        EXPECT_EQ(solve(system_of(*q, m), config("serial", "soa", precision, 32, 1)).B, want.B);
        for (const char* layout : {"aos", "soa"})
          for (int threads : {1, 2, 3})
            EXPECT_EQ(solve(system_of(*q, m), config("openmp", layout, precision, 32, threads)).B, want.B)
                << layout << " " << threads;
      }
}

// auto: the fewest bytes per step of the storages the backend reads. Room3's density (18%) takes runs in float32
// and 16 bits on the CPU backends, mpi included (compressed where runs are not read: the GPU backends, which read
// the sparse storages and dense float32 only); a closed box (83%) keeps dense; a backend that reads dense only gets
// dense.
TEST(Sparse, AutoPicksTheFewestBytesPerStep) {
  const SolveBackend* openmp = nullptr;
  const SolveBackend* cuda = nullptr;
  const SolveBackend* hybrid = nullptr;
  const SolveBackend* mpi = nullptr;
  for (const SolveBackend& b : solve_backends()) {
    if (b.name == "openmp") openmp = &b;
    if (b.name == "cuda") cuda = &b;
    if (b.name == "hybrid") hybrid = &b;
    if (b.name == "mpi") mpi = &b;
  }
  ASSERT_TRUE(openmp && cuda && hybrid && mpi);
  // mpi reads every storage, runs too (each rank its rows' runs matrix), so it picks as openmp does
  for (FFValues v : {FFValues::float32, FFValues::float16, FFValues::bfloat16})
    EXPECT_EQ(readable_storages(*mpi, v), readable_storages(*openmp, v)) << to_string(v);
  // room3 at R = 256, every row: 17470512 kept in 737073 runs of 19947864 values at the default merge gap
  const StorageCounts room3{9680, 17470512, 0, 9680, RunCounts{737073, 19947864}};
  for (FFValues v : {FFValues::float32, FFValues::float16}) {
    EXPECT_EQ(fewest_bytes_storage(readable_storages(*openmp), v, room3), FFStorage::runs) << to_string(v);
    EXPECT_EQ(fewest_bytes_storage(readable_storages(*cuda, v), v, room3), FFStorage::compressed) << to_string(v);
  }
  EXPECT_EQ(fewest_bytes_storage({FFStorage::dense, FFStorage::csr, FFStorage::compressed}, FFValues::float16, room3),
            FFStorage::compressed);
  EXPECT_EQ(fewest_bytes_storage(readable_storages(*hybrid), FFValues::float32, room3), FFStorage::dense);
  EXPECT_EQ(readable_storages(*cuda, FFValues::float16),
            (std::vector<FFStorage>{FFStorage::csr, FFStorage::compressed}));
  const StorageCounts box{600, 300000, 0, 600, RunCounts{600 * 40, 340000}};
  for (FFValues v : {FFValues::float32, FFValues::float16})
    EXPECT_EQ(fewest_bytes_storage(readable_storages(*openmp), v, box), FFStorage::dense) << to_string(v);
  // csr only where it is the only sparse storage read; dense on a tie
  EXPECT_EQ(fewest_bytes_storage({FFStorage::dense, FFStorage::csr}, FFValues::float32, room3), FFStorage::csr);
  const StorageCounts tie{100, 0, 0, 0, RunCounts{0, 0}};
  EXPECT_EQ(fewest_bytes_storage(readable_storages(*openmp), FFValues::float32, tie), FFStorage::dense);
  // runs that were not counted are never taken for free
  EXPECT_THROW(step_bytes(FFStorage::runs, FFValues::float16, StorageCounts{9680, 17470512, 0, 9680, RunCounts{}}),
               std::invalid_argument);
  EXPECT_DOUBLE_EQ(step_bytes(FFStorage::runs, FFValues::float16, room3), 2.0 * 19947864 + 4.0 * 737073 + 16 * 9681);
  EXPECT_EQ(parse_ff_storage("runs"), FFStorage::runs);
  // counted on matrices: occluded rows take runs, a matrix without zeros (a closed box's) keeps dense
  for (const auto& [share, want] : {std::pair{0.8, FFStorage::runs}, {0.0, FFStorage::dense}}) {
    const Problem p = occluded_problem(300, 87, share);
    const size_t n = p.sys.n, kept = count_kept(p.F.data(), n, p.sys.reflectivity, 0);
    const StorageCounts counts{n, kept, 0, n, count_runs(p.F.data(), n, p.sys.reflectivity, FFMatrixOptions{})};
    for (FFValues v : {FFValues::float32, FFValues::float16})
      EXPECT_EQ(fewest_bytes_storage(readable_storages(*openmp), v, counts), want) << share << " " << to_string(v);
  }
  EXPECT_DOUBLE_EQ(step_bytes(FFStorage::compressed, FFValues::float16, room3), 4.0 * 17470512 + 8 * 9681);
  EXPECT_DOUBLE_EQ(step_bytes(FFStorage::dense, FFValues::float32, room3), 4.0 * 9680 * 9680);
  EXPECT_EQ(parse_ff_storage("compressed"), FFStorage::compressed);
}
