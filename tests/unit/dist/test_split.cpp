// Row blocks for MPI ranks: contiguous, in rank order, covering every row, each block's work within one row's work of
// an equal share, and the same bounds for the same input (every rank computes them alone).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "radiosity/dist/split.hpp"

using radiosity::dist::block_of;
using radiosity::dist::split_by_work;

namespace {

// Bounds are a partition of 0..n in order; each block's work is within max(w) of total/parts.
void expect_balanced(const std::vector<uint64_t>& w, int parts) {
  const std::vector<size_t> b = split_by_work(w, parts);
  ASSERT_EQ(b.size(), size_t(parts) + 1);
  EXPECT_EQ(b.front(), 0u);
  EXPECT_EQ(b.back(), w.size());
  EXPECT_TRUE(std::is_sorted(b.begin(), b.end()));
  const double total = std::accumulate(w.begin(), w.end(), 0.0);
  const double biggest = w.empty() ? 0.0 : double(*std::max_element(w.begin(), w.end()));
  for (int r = 0; r < parts; ++r) {
    double mine = 0;
    for (size_t i = b[r]; i < b[r + 1]; ++i) mine += double(w[i]);
    EXPECT_LE(mine, total / parts + biggest) << "block " << r << " of " << parts;
    EXPECT_GE(mine, total / parts - biggest) << "block " << r << " of " << parts;
  }
}

}  // namespace

TEST(Split, EqualWorkGivesBlocksThatDifferByAtMostOneRow) {
  for (size_t n : {1u, 2u, 7u, 10u, 1312u, 3360u})
    for (int p = 1; p <= 8; ++p) {
      const std::vector<size_t> b = split_by_work(std::vector<uint64_t>(n, 5), p);
      size_t lo = n, hi = 0;
      for (int r = 0; r < p; ++r) {
        lo = std::min(lo, b[r + 1] - b[r]);
        hi = std::max(hi, b[r + 1] - b[r]);
      }
      EXPECT_LE(hi - lo, 1u) << n << " rows, " << p << " parts";
    }
}

TEST(Split, TenRowsInThreeIsFourThreeThree) {
  EXPECT_EQ(split_by_work(std::vector<uint64_t>(10, 1), 3), (std::vector<size_t>{0, 4, 7, 10}));
}

TEST(Split, OnePartIsEveryRow) { EXPECT_EQ(split_by_work({3, 1, 4, 1, 5}, 1), (std::vector<size_t>{0, 5})); }

TEST(Split, SkewedWorkGivesFewerRowsToTheHeavyEnd) {
  // Rows 0..99 cost 1, rows 100..199 cost 3: half the work (200 of 400) is done after row 133 (100 + 34·3 = 202).
  std::vector<uint64_t> w(200, 1);
  std::fill(w.begin() + 100, w.end(), 3);
  const std::vector<size_t> b = split_by_work(w, 2);
  EXPECT_EQ(b[1], 134u);
  expect_balanced(w, 2);
}

TEST(Split, BalancedForRandomWork) {
  std::mt19937_64 rng(9);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<uint64_t> w(1 + rng() % 500);
    for (auto& x : w) x = 1 + rng() % 10000;
    expect_balanced(w, 1 + int(rng() % 16));
  }
}

TEST(Split, MorePartsThanRowsLeavesSomeBlocksEmpty) {
  const std::vector<size_t> b = split_by_work({1, 1}, 4);
  EXPECT_EQ(b, (std::vector<size_t>{0, 1, 1, 2, 2}));
  size_t rows = 0;
  for (int r = 0; r < 4; ++r) rows += block_of(b, r).rows();
  EXPECT_EQ(rows, 2u);
}

TEST(Split, OneRowHeavierThanAShare) {
  expect_balanced({1, 1, 100, 1, 1}, 3);
  const std::vector<size_t> b = split_by_work({1, 1, 100, 1, 1}, 3);
  EXPECT_EQ(block_of(b, 0).end, 3u);  // the heavy row ends the first block that reaches a share
}

TEST(Split, HugeWorkDoesNotOverflow) {
  const std::vector<uint64_t> w(1000, uint64_t(1) << 62);
  const std::vector<size_t> b = split_by_work(w, 7);
  EXPECT_EQ(b.back(), 1000u);
  expect_balanced(w, 7);
}

TEST(Split, NoPartsIsRefused) { EXPECT_THROW(split_by_work({1}, 0), std::invalid_argument); }
