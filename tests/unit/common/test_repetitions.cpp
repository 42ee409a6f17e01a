// hpcgi::repeat_for (--min-time): a run as long as the minimum time is the answer alone; a shorter one is a warm-up,
// the repetitions that follow sum to at least the minimum time, and the answer is the median repetition's (the lower
// median of an even count), whatever order the times come in.
#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "common/repetitions.hpp"

namespace {

struct Fake {
  int index;
  double seconds;
};

// run() hands out the given times in order, each result naming its position.
struct Runs {
  std::vector<double> times;
  int next = 0;
  Fake operator()() {
    const int i = next++;
    return {i, times.at(static_cast<size_t>(i))};
  }
};

double seconds(const Fake& f) { return f.seconds; }

}  // namespace

TEST(Repetitions, NoMinimumTimeIsOneRun) {
  Runs runs{{0.004}};
  hpcgi::Repetitions reps;
  const Fake f = hpcgi::repeat_for(0.0, runs, seconds, reps);
  EXPECT_EQ(f.index, 0);
  EXPECT_EQ(runs.next, 1);
  EXPECT_LT(reps.warmup_s, 0);
  EXPECT_EQ(reps.times_s, std::vector<double>{0.004});
  EXPECT_EQ(reps.chosen, 0);
}

TEST(Repetitions, ARunAsLongAsTheMinimumIsTheAnswerWithoutWarmUp) {
  Runs runs{{0.25, 1.0}};
  hpcgi::Repetitions reps;
  const Fake f = hpcgi::repeat_for(0.1, runs, seconds, reps);
  EXPECT_EQ(f.index, 0);
  EXPECT_EQ(runs.next, 1);
  EXPECT_LT(reps.warmup_s, 0);
  EXPECT_EQ(reps.times_s.size(), 1u);
}

TEST(Repetitions, AShortRunIsAWarmUpAndTheMedianRepetitionIsTheAnswer) {
  // warm-up 0.05, then 0.03 0.01 0.02 0.04 0.02: they reach 0.1 after the fourth (0.03+0.01+0.02+0.04 = 0.10)
  Runs runs{{0.05, 0.03, 0.01, 0.02, 0.04, 0.02}};
  hpcgi::Repetitions reps;
  const Fake f = hpcgi::repeat_for(0.1, runs, seconds, reps);
  EXPECT_EQ(runs.next, 5);
  EXPECT_DOUBLE_EQ(reps.warmup_s, 0.05);
  ASSERT_EQ(reps.times_s.size(), 4u);
  EXPECT_GE(std::accumulate(reps.times_s.begin(), reps.times_s.end(), 0.0), 0.1 - 1e-12);
  // sorted 0.01 0.02 0.03 0.04: the lower median is 0.02, the third run (index 3 of the fake, 2 of the repetitions)
  EXPECT_EQ(reps.chosen, 2);
  EXPECT_EQ(f.index, 3);
  EXPECT_DOUBLE_EQ(f.seconds, 0.02);
}

TEST(Repetitions, AnOddCountTakesTheMiddle) {
  Runs runs{{0.001, 0.5, 0.1, 0.3}};  // a warm-up, then three repetitions to reach 0.8
  hpcgi::Repetitions reps;
  const Fake f = hpcgi::repeat_for(0.8, runs, seconds, reps);
  ASSERT_EQ(reps.times_s.size(), 3u);  // 0.5 + 0.1 + 0.3 = 0.9 >= 0.8
  EXPECT_DOUBLE_EQ(f.seconds, 0.3);     // sorted 0.1 0.3 0.5
  EXPECT_EQ(reps.chosen, 2);
}

TEST(Repetitions, TheRecordSectionSaysWhatWasDone) {
  Runs runs{{0.05, 0.06, 0.07}};
  hpcgi::Repetitions reps;
  hpcgi::repeat_for(0.1, runs, seconds, reps);
  const nlohmann::json j = hpcgi::to_json(reps);
  EXPECT_DOUBLE_EQ(j["min_time_s"].get<double>(), 0.1);
  EXPECT_DOUBLE_EQ(j["warmup_s"].get<double>(), 0.05);
  EXPECT_EQ(j["count"].get<long>(), 2);
  EXPECT_EQ(j["chosen"].get<long>(), 0);
  EXPECT_NE(hpcgi::describe(reps).find("the median of 2 solves"), std::string::npos);
  hpcgi::Repetitions one;
  hpcgi::repeat_for(0.0, Runs{{0.2}}, seconds, one);
  EXPECT_TRUE(hpcgi::to_json(one)["warmup_s"].is_null());
  EXPECT_EQ(hpcgi::describe(one), "");
}
