// hpcgi::read_share: the threads' shares of an array read every byte once, so their sums add up to the array's word
// sum, for any length (partial lines, partial words) and thread count; and word_sum is the 64-bit words' sum.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "common/read_sweep.hpp"

TEST(ReadSweep, WordSumIsTheSumOfTheZeroPaddedWords) {
  const unsigned char b[11] = {1, 0, 0, 0, 0, 0, 0, 0, 2, 3, 0};
  EXPECT_EQ(hpcgi::word_sum(b, 8), 1u);
  EXPECT_EQ(hpcgi::word_sum(b, 11), 1u + 2u + (3u << 8));
  EXPECT_EQ(hpcgi::word_sum(b, 0), 0u);
  const uint64_t big[2] = {~uint64_t(0), 2};  // wraps
  EXPECT_EQ(hpcgi::word_sum(big, sizeof big), 1u);
}

TEST(ReadSweep, SharesAddUpToTheWholeForAnyLengthAndThreads) {
  std::mt19937_64 g(37);
  std::vector<unsigned char> a(5000);
  for (auto& c : a) c = static_cast<unsigned char>(g());
  for (size_t bytes : {size_t(0), size_t(7), size_t(8), size_t(63), size_t(64), size_t(255), size_t(256),
                       size_t(257), size_t(1031), size_t(4999)})
    for (int nt = 1; nt <= 7; ++nt)
      for (size_t prefetch : {size_t(0), size_t(128)}) {
        uint64_t sum = 0;
        for (int t = 0; t < nt; ++t) sum += hpcgi::read_share(a.data() + 1, bytes, t, nt, prefetch);
        EXPECT_EQ(sum, hpcgi::word_sum(a.data() + 1, bytes)) << bytes << " bytes, " << nt << " threads";
      }
}

TEST(ReadSweep, AChangedByteChangesTheSum) {
  std::vector<unsigned char> a(1000, 1);
  const uint64_t before = hpcgi::read_share(a.data(), a.size(), 0, 1);
  a[777] = 2;
  EXPECT_NE(hpcgi::read_share(a.data(), a.size(), 0, 1), before);
}
