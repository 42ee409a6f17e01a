// The sparse products (csr_kernels.hpp, runs_kernels.hpp) and the compressed and runs storages (ff_matrix.hpp): the
// same answers as dense, the same bits wherever the summation order is the same, the bridges of long gaps, the split
// of rows by entries, and what --storage auto picks (storage_choice.hpp).
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
#include "radiosity/formfactor/ff_file.hpp"
#include "radiosity/scene/analytic.hpp"
#include "radiosity/solve/host/csr_kernels.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"
#include "radiosity/solve/storage/ff_matrix_file.hpp"
#include "radiosity/solve/solve.hpp"
#include "radiosity/solve/storage_choice.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

// random_problem with about `zero_share` of F set to 0 in runs (occlusion hides neighbouring patches together).
Problem occluded_problem(size_t n, unsigned seed, double zero_share) {
  Problem p = random_problem(n, seed);
  std::mt19937_64 rng(seed + 7);
  std::uniform_real_distribution<double> u(0, 1);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n;) {
      const size_t run = 1 + size_t(u(rng) * 12);
      const bool zero = u(rng) < zero_share;
      for (size_t r = 0; r < run && j < n; ++r, ++j)
        if (zero) p.F[i * n + j] = 0;
    }
  return p;
}

SolveConfig config(const std::string& backend, const std::string& layout, const std::string& precision, long steps,
                   int threads = 2, const std::string& method = "jacobi") {
  return solve_config(backend, layout, method, precision, steps, threads);
}

FormFactorMatrix stored(const Problem& p, FFStorage storage, FFValues values, uint32_t max_step = kMaxStep,
                        uint32_t merge_gap = kRunMergeGap, uint32_t max_length = kRunMaxLength) {
  FFMatrixOptions o;
  o.storage = storage;
  o.values = values;
  o.max_step = max_step;
  o.merge_gap = merge_gap;
  o.max_length = max_length;
  return FormFactorMatrix(p.F.data(), p.sys.n, p.sys.reflectivity, o);
}

System system_of(const Problem& p, const FormFactorMatrix& m) {
  System s = p.sys;
  s.matrix = m.view();
  return s;
}

}  // namespace

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

// Runs hold every kept F_ij at its column and zeros in the merged gaps only; a gap above max_step takes runs of
// length 0, a run above max_step or max_length is split; count_runs counts what the matrix holds; the answer does
// not change (a small max_step, merge gaps from 0 to 50 and run lengths from 5 to 65535 exercise each case on a
// small matrix).
TEST(Sparse, RunsHoldTheKeptValuesWithBridgesAndMergedGaps) {
  const Problem p = occluded_problem(150, 83, 0.85);
  const FormFactorMatrix plain = stored(p, FFStorage::runs, FFValues::float32);
  EXPECT_EQ(plain.bridges(), 0u);
  const SolveConfig c = config("openmp", "soa", "double", 32);
  const SolveResult want = solve(system_of(p, plain), c);
  for (uint32_t max_length : {5u, kRunMaxLength, kMaxStep}) {
    size_t runs_at_0 = 0;
    for (uint32_t max_step : {1u, 3u, 40u, kMaxStep})
      for (uint32_t gap : {0u, 2u, 50u}) {
        SCOPED_TRACE(std::to_string(max_length) + " " + std::to_string(max_step) + " " + std::to_string(gap));
        const FormFactorMatrix m = stored(p, FFStorage::runs, FFValues::float32, max_step, gap, max_length);
        FFMatrixOptions o;
        o.max_step = max_step;
        o.merge_gap = gap;
        o.max_length = max_length;
        const RunCounts counted = count_runs(p.F.data(), p.sys.n, p.sys.reflectivity, o);
        EXPECT_EQ(m.runs().runs, counted.runs);
        EXPECT_EQ(m.runs().entries, counted.entries);
        EXPECT_EQ(m.kept(), plain.kept());
        EXPECT_GE(m.runs().entries, m.kept());
        if (gap == 0) {
          EXPECT_EQ(m.runs().entries, m.kept());
        }
        if (max_step == kMaxStep && gap == 0) runs_at_0 = m.runs().runs;
        if (max_step == kMaxStep && gap == 50 && max_length == kMaxStep) {
          EXPECT_LT(m.runs().runs, runs_at_0);  // merging joins runs where their length is not capped
        }
        const FFMatrixView v = m.view();
        size_t bridges = 0;
        for (int64_t r = 0; r < v.run_start[p.sys.n]; ++r) {
          bridges += v.run[r].length == 0;
          EXPECT_LE(v.run[r].step, max_step);
          EXPECT_LE(v.run[r].length, std::min(max_step, max_length));
        }
        EXPECT_EQ(bridges, m.bridges());
        if (max_step == 1) {
          EXPECT_GT(m.bridges(), 0u);
        }
        for (size_t i = 0; i < p.sys.n; ++i) {  // every kept F_ij at its column, every other stored value 0
          size_t kept = 0;
          int64_t prev = -1;
          for_each_entry(v, i, [&](size_t k, size_t j) {
            const float f = static_cast<const float*>(v.data)[k];
            ASSERT_LT(j, p.sys.n);
            EXPECT_GT(int64_t(j), prev);
            prev = int64_t(j);
            EXPECT_EQ(f, p.F[i * p.sys.n + j]);
            kept += f != 0;
          });
          size_t expected = 0;
          for (size_t j = 0; j < p.sys.n; ++j) expected += p.F[i * p.sys.n + j] != 0;
          EXPECT_EQ(kept, expected) << "row " << i;
        }
        EXPECT_LE(rel_diff(solve(system_of(p, m), c).B, want.B), 1e-14);
        EXPECT_DOUBLE_EQ(m.bytes(), 4.0 * double(m.runs().entries) + 4.0 * double(m.runs().runs) + 16 * 151);
      }
  }
}

// Rows of patches with reflectivity 0 are left empty: neither stored nor read, and the patch keeps its emission.
TEST(Sparse, RunsLeaveRowsOfReflectivityZeroEmpty) {
  Problem p = occluded_problem(120, 85, 0.6);
  for (size_t i = 0; i < p.sys.n; i += 7) p.sys.reflectivity[i] = Rgb{0, 0, 0};
  const FormFactorMatrix m = stored(p, FFStorage::runs, FFValues::float16);
  const FFMatrixView v = m.view();
  for (size_t i = 0; i < p.sys.n; i += 7) {
    EXPECT_EQ(v.row_start[i + 1], v.row_start[i]);
    EXPECT_EQ(v.run_start[i + 1], v.run_start[i]);
  }
  const SolveConfig c = config("openmp", "aos", "double", 0);
  const SolveResult r = solve(system_of(p, m), c);
  for (size_t i = 0; i < p.sys.n; i += 7) EXPECT_EQ(r.B[i], p.sys.emission[i]);
  EXPECT_LE(rel_diff(r.B, solve(p.sys, c).B), 10 * 0x1p-11);
}

// A gap longer than the largest step is bridged by entries of value 0: counted alike by count_bridges and the
// matrix, and the answer unchanged (max_step 3 here makes every long gap of a small matrix a bridge).
TEST(Sparse, LongGapsAreBridged) {
  const Problem p = occluded_problem(150, 77, 0.85);
  const FormFactorMatrix plain = stored(p, FFStorage::compressed, FFValues::float32);
  EXPECT_EQ(plain.bridges(), 0u);
  for (uint32_t max_step : {1u, 3u, 40u}) {
    SCOPED_TRACE(max_step);
    const FormFactorMatrix m = stored(p, FFStorage::compressed, FFValues::float32, max_step);
    EXPECT_EQ(m.kept(), plain.kept());
    EXPECT_EQ(m.bridges(), count_bridges(p.F.data(), p.sys.n, p.sys.reflectivity, 0, 0, SIZE_MAX, max_step));
    if (max_step < 40) {
      EXPECT_GT(m.bridges(), 0u);
    }
    EXPECT_DOUBLE_EQ(m.bytes(), 6.0 * double(m.kept() + m.bridges()) + 8 * 151);
    const FFMatrixView v = m.view();
    for (size_t i = 0; i < p.sys.n; ++i) {  // every kept F_ij at its column, every bridge 0
      size_t kept = 0;
      for_each_entry(v, i, [&](size_t k, size_t j) {
        const float f = static_cast<const float*>(v.data)[k];
        ASSERT_LT(j, p.sys.n);
        if (f != 0) {
          EXPECT_EQ(f, p.F[i * p.sys.n + j]);
          ++kept;
        }
      });
      size_t want = 0;
      for (size_t j = 0; j < p.sys.n; ++j) want += p.F[i * p.sys.n + j] != 0;
      EXPECT_EQ(kept, want) << "row " << i;
    }
    const SolveConfig c = config("openmp", "soa", "double", 32);
    EXPECT_LE(rel_diff(solve(system_of(p, m), c).B, solve(system_of(p, plain), c).B), 1e-14);
  }
  FFMatrixOptions bad;
  bad.storage = FFStorage::compressed;
  bad.max_step = 0;
  EXPECT_THROW(FormFactorMatrix(p.F.data(), p.sys.n, p.sys.reflectivity, bad), hpcgi::UsageError);
}

// Threads share rows by entries: the blocks cover the rows in order, start on multiples of kRowAlign, and on rows
// of very different lengths each holds about its share of the cost (at most one block of kRowAlign rows more).
TEST(Sparse, RowsAreSplitByEntries) {
  const size_t n = 1000;
  std::vector<int64_t> start(n + 1, 0);
  for (size_t i = 0; i < n; ++i) start[i + 1] = start[i] + (i < 100 ? 2000 : 10);  // the first rows are long
  for (size_t r0 : {size_t(0), size_t(37)})
    for (int nt : {1, 2, 3, 7}) {
      SCOPED_TRACE(std::to_string(r0) + " " + std::to_string(nt));
      auto cost = [&](size_t a, size_t b) { return double(start[b] - start[a]) + double(kRowCost) * double(b - a); };
      size_t at = r0;
      for (int t = 0; t < nt; ++t) {
        const auto [b, e] = entry_block(start.data(), r0, n, t, nt);
        EXPECT_EQ(b, at);
        EXPECT_TRUE(b == n || (b - r0) % kRowAlign == 0);
        EXPECT_LE(cost(b, e), cost(r0, n) / nt + cost(0, kRowAlign) + 1);
        at = e;
      }
      EXPECT_EQ(at, n);
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

// The sparse form-factor file (version 2): what is written is read back to the bit, and solves as the matrix it was
// made from; a damaged file is refused with one line, and the dense readers refuse a sparse file.
class SparseFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::path(::testing::TempDir()) /
           ("hpcgi_sparse_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
    mesh_ = two_facing_squares(6);
    p_.emplace(occluded_problem(mesh_.size(), 79, 0.75));
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  FormFactorMatrix every_row(FFStorage st, FFValues v) const {
    FFMatrixOptions o;
    o.storage = st;
    o.values = v;
    return FormFactorMatrix(p().F.data(), p().sys.n, std::vector<Rgb>(p().sys.n, Rgb{1, 1, 1}), o);
  }
  std::string bytes_of(const std::string& f) const {
    std::ifstream in(f, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  void write_bytes(const std::string& f, const std::string& b) const {
    std::ofstream(f, std::ios::binary | std::ios::trunc).write(b.data(), std::streamsize(b.size()));
  }
  // The file's bytes d with the payload's checksum made right again (so that the structure checks are reached).
  static std::string with_checksum(std::string d) {
    Fnv64 sum;
    sum.update(d.data() + kFormFactorHeaderBytes, d.size() - kFormFactorHeaderBytes - 8);
    const uint64_t h = sum.finish();
    std::memcpy(&d[d.size() - 8], &h, 8);
    return d;
  }
  // The message of the refusal to load f (empty if it loads).
  std::string refusal(const std::string& f) const {
    try {
      load_form_factor_matrix(f, mesh_, nullptr);
    } catch (const hpcgi::UsageError& e) {
      return e.what();
    }
    return "";
  }
  std::filesystem::path dir_;
  Mesh mesh_;
  std::optional<Problem> p_;
  const Problem& p() const { return *p_; }
  HemicubeParams params_{64, HemicubeWeights::exact, 0};
};

TEST_F(SparseFile, RoundTripKeepsEveryBitAndSolvesTheSame) {
  for (FFStorage st : {FFStorage::csr, FFStorage::compressed, FFStorage::runs})
    for (FFValues v : {FFValues::float32, FFValues::float16, FFValues::bfloat16}) {
      SCOPED_TRACE(std::string(to_string(st)) + " " + to_string(v));
      const FormFactorMatrix m = every_row(st, v);
      const std::string f = path("f.ff");
      save_form_factor_matrix(f, mesh_, params_, m);
      const size_t entries = size_t(m.view().row_start[m.view().n]);
      EXPECT_EQ(double(std::filesystem::file_size(f)),
                double(kFormFactorHeaderBytes) + sparse_payload_bytes(st, v, m.view().n, entries, m.runs().runs) + 8);
      HemicubeParams read_params;
      const FormFactorMatrix back = load_form_factor_matrix(f, mesh_, &read_params);
      EXPECT_EQ(read_params.resolution, 64);
      EXPECT_EQ(back.kept(), m.kept());
      EXPECT_EQ(back.bridges(), m.bridges());
      EXPECT_EQ(back.runs().runs, m.runs().runs);
      EXPECT_EQ(back.bytes(), m.bytes());
      EXPECT_EQ(back.view().scale, m.view().scale);
      const SolveConfig c = config("openmp", "aos", "float", 16);
      EXPECT_EQ(solve(system_of(p(), back), c).B, solve(system_of(p(), m), c).B);
      EXPECT_THROW(check_form_factor_file(f, mesh_), hpcgi::UsageError);  // the dense readers refuse it
      try {
        load_form_factors(f, mesh_);
        ADD_FAILURE() << "a dense reader loaded a sparse file";
      } catch (const hpcgi::UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("version 2"), std::string::npos) << e.what();
      }
    }
}

TEST_F(SparseFile, DamagedFilesAreRefused) {
  const std::string f = path("f.ff");
  save_form_factor_matrix(f, mesh_, params_, every_row(FFStorage::compressed, FFValues::float16));
  const std::string good = bytes_of(f);
  std::string b = good;
  b[good.size() - 20] ^= 1;  // a value's bit
  write_bytes(f, b);
  EXPECT_NE(refusal(f).find("checksum mismatch"), std::string::npos) << refusal(f);
  write_bytes(f, good.substr(0, good.size() - 3));
  EXPECT_NE(refusal(f).find("truncated"), std::string::npos) << refusal(f);
  // A step that takes a row past the last column, with its checksum made right: the structure check refuses it.
  b = good;
  const size_t n = mesh_.size(), steps_at = kFormFactorHeaderBytes + 32 + 8 * (n + 1);
  b[steps_at] = char(0xff), b[steps_at + 1] = char(0xff);
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("column 65534"), std::string::npos) << refusal(f);
  // a dense file is no sparse one
  FormFactors dense{n, p().F, params_};
  save_form_factors(f, mesh_, dense);
  EXPECT_NE(refusal(f).find("version 1"), std::string::npos) << refusal(f);
}

// An MPI rank's matrix (backend mpi): built from its block of rows alone, it indexes every row, holds its own rows
// as the whole matrix holds them (the same values, columns or steps, in the same order) and leaves the others empty;
// with the largest value given (every rank's), float16 rounds as the whole matrix does. Dense keeps the block's rows.
TEST(Sparse, RowBlockMatrixHoldsItsRowsAsTheWholeMatrix) {
  const Problem p = occluded_problem(157, 5, 0.7);
  const size_t n = p.sys.n, b0 = 40, b1 = 97;
  const float* block = p.F.data() + b0 * n;
  for (FFStorage st : {FFStorage::dense, FFStorage::csr, FFStorage::compressed})
    for (FFValues v : {FFValues::float32, FFValues::float16}) {
      FFMatrixOptions o;
      o.storage = st;
      o.values = v;
      const FormFactorMatrix whole(p.F.data(), n, p.sys.reflectivity, o);
      o.largest = largest_abs(p.F.data(), n * n);
      const FormFactorMatrix part(block, n, p.sys.reflectivity, o, b0, b1);
      const FFMatrixView w = whole.view(), r = part.view();
      ASSERT_EQ(r.scale, w.scale) << to_string(st) << " " << to_string(v);
      const size_t vb = value_bytes(v);
      if (st == FFStorage::dense) {
        EXPECT_EQ(std::memcmp(r.data, static_cast<const char*>(w.data) + b0 * n * vb, (b1 - b0) * n * vb), 0);
        continue;
      }
      for (size_t i = 0; i < n; ++i) {
        const int64_t len = r.row_start[i + 1] - r.row_start[i];
        ASSERT_EQ(len, i >= b0 && i < b1 ? w.row_start[i + 1] - w.row_start[i] : 0) << i;
      }
      const size_t k0 = size_t(w.row_start[b0]), count = size_t(w.row_start[b1]) - k0;
      EXPECT_EQ(std::memcmp(r.data, static_cast<const char*>(w.data) + k0 * vb, count * vb), 0);
      if (st == FFStorage::csr)
        EXPECT_EQ(std::memcmp(r.col, w.col + k0, count * 4), 0);
      else
        EXPECT_EQ(std::memcmp(r.step, w.step + k0, count * 2), 0);
    }
}

// An MPI rank's runs matrix: built from its block of rows alone (rows of reflectivity 0 among them, bridges and
// split runs from small largest steps), it indexes every row (row and run starts), holds each of its rows' runs and
// values as the whole matrix holds them and leaves the others empty; the blocks of a split together hold the whole
// matrix's values, runs, kept values and bridges, count_runs of a block counts what its matrix holds, and float16
// with the largest value given rounds as the whole matrix does.
TEST(Sparse, RowBlockRunsMatrixHoldsItsRowsAsTheWholeMatrix) {
  Problem p = occluded_problem(157, 11, 0.7);
  const size_t n = p.sys.n;
  for (size_t i = 3; i < n; i += 7) p.sys.reflectivity[i] = Rgb{0, 0, 0};
  const std::vector<size_t> bounds = {0, 0, 40, 41, 97, 157};  // an empty block, a block of one row
  for (uint32_t max_step : {1u, 3u, 40u, kMaxStep})
    for (FFValues v : {FFValues::float32, FFValues::float16}) {
      SCOPED_TRACE(std::to_string(max_step) + " " + to_string(v));
      FFMatrixOptions o;
      o.storage = FFStorage::runs;
      o.values = v;
      o.max_step = max_step;
      const FormFactorMatrix whole(p.F.data(), n, p.sys.reflectivity, o);
      const FFMatrixView w = whole.view();
      if (max_step <= 3) {
        ASSERT_GT(whole.bridges(), 0u);  // long gaps bridged
      }
      o.largest = largest_abs(p.F.data(), n * n);
      size_t kept = 0, bridges = 0, runs = 0, entries = 0;
      const size_t vb = value_bytes(v);
      for (size_t b = 0; b + 1 < bounds.size(); ++b) {
        const size_t b0 = bounds[b], b1 = bounds[b + 1];
        const FormFactorMatrix part(p.F.data() + b0 * n, n, p.sys.reflectivity, o, b0, b1);
        const FFMatrixView r = part.view();
        ASSERT_EQ(r.scale, w.scale);
        ASSERT_EQ(r.row_start[0], 0);
        ASSERT_EQ(r.run_start[0], 0);
        for (size_t i = 0; i < n; ++i) {
          const bool mine = i >= b0 && i < b1;
          const int64_t len = r.row_start[i + 1] - r.row_start[i], count = r.run_start[i + 1] - r.run_start[i];
          ASSERT_EQ(len, mine ? w.row_start[i + 1] - w.row_start[i] : 0) << i;
          ASSERT_EQ(count, mine ? w.run_start[i + 1] - w.run_start[i] : 0) << i;
          if (!mine || count == 0) continue;
          EXPECT_EQ(std::memcmp(r.run + r.run_start[i], w.run + w.run_start[i], size_t(count) * sizeof(FFRun)), 0) << i;
          EXPECT_EQ(std::memcmp(static_cast<const char*>(r.data) + size_t(r.row_start[i]) * vb,
                                static_cast<const char*>(w.data) + size_t(w.row_start[i]) * vb, size_t(len) * vb),
                    0)
              << i;
        }
        for (size_t i = b0; i < b1; ++i) {
          if (!row_needed(p.sys.reflectivity[i])) {
            EXPECT_EQ(r.run_start[i + 1], r.run_start[i]) << i;
          }
        }
        const RunCounts counted = count_runs(p.F.data() + b0 * n, n, p.sys.reflectivity, o, b0, b1);
        EXPECT_EQ(part.runs().runs, counted.runs);
        EXPECT_EQ(part.runs().entries, counted.entries);
        EXPECT_DOUBLE_EQ(part.bytes(), ff_storage_bytes(FFStorage::runs, v, n, 0, 0, counted));
        kept += part.kept();
        bridges += part.bridges();
        runs += part.runs().runs;
        entries += part.runs().entries;
      }
      EXPECT_EQ(kept, whole.kept());
      EXPECT_EQ(bridges, whole.bridges());
      EXPECT_EQ(runs, whole.runs().runs);
      EXPECT_EQ(entries, whole.runs().entries);
    }
}

// A runs file is checked as csr and compressed files are: its checksum, and with the checksum made right, runs that
// do not cover their row's values or that take a row past its last column.
TEST_F(SparseFile, DamagedRunsFilesAreRefused) {
  const std::string f = path("f.ff");
  save_form_factor_matrix(f, mesh_, params_, every_row(FFStorage::runs, FFValues::float16));
  const std::string good = bytes_of(f);
  std::string b = good;
  b[good.size() - 20] ^= 1;  // a value's bit
  write_bytes(f, b);
  EXPECT_NE(refusal(f).find("checksum mismatch"), std::string::npos) << refusal(f);
  const size_t n = mesh_.size(), runs_at = kFormFactorHeaderBytes + 32 + 8 * (n + 1) + 8 + 8 * (n + 1);
  b = good;
  b[runs_at + 2] = char(b[runs_at + 2] + 1);  // the first run one value longer than its row holds
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("runs of"), std::string::npos) << refusal(f);
  b = good;
  b[runs_at] = char(0xff), b[runs_at + 1] = char(0xff);  // the first run starts past the last column
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("column 65535"), std::string::npos) << refusal(f);
  b = good;
  b[kFormFactorHeaderBytes + 32] ^= 1;  // the count of runs
  write_bytes(f, with_checksum(b));
  EXPECT_NE(refusal(f).find("runs) in a payload"), std::string::npos) << refusal(f);
  write_bytes(f, good);
  EXPECT_EQ(refusal(f), "");
}
