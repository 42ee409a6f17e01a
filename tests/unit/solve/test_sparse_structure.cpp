// How the compressed and runs storages hold F (ff_matrix.hpp): runs with bridges and merged gaps, empty rows of
// reflectivity 0, the bridges of long gaps, the split of rows by entries among threads, and an MPI rank's matrix of
// its block of rows as the whole matrix holds them.
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
