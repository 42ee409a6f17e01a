// --min-time S (bin/poisson, bin/radiosity solve): a solve of a few milliseconds timed as the median of many in one
// process, as Google Benchmark's --benchmark_min_time and pyperf's loops do. One run of a 3 ms solve is at the mercy
// of one thread held up for a millisecond (on a 2-vCPU VM the OpenMP time of scene 1 is either 1.7 ms or 3 ms from
// one process to the next); the median of 30 in one process is not (issue 49).
//
// The solve runs once. Where it took at least S seconds (on the slowest MPI rank) it is the answer, as without the
// option. Else that run was a warm-up (thread start, first touch of the arrays): the solve is repeated from the same
// start until the repetitions' times sum to S (at least one, at most kMaxRepetitions), and the result of the median
// repetition is the answer (the lower median of an even count). Every rank runs the same repetitions: the slowest
// rank's time decides, so that the ranks agree without another message.
#pragma once
#include <algorithm>
#include <cstdio>
#include <numeric>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/comm.hpp"

namespace hpcgi {

inline constexpr long kMaxRepetitions = 10000;

struct Repetitions {
  double min_time_s = 0;
  double warmup_s = -1;         // the first run's time where it was a warm-up, else -1 (it was the answer)
  std::vector<double> times_s;  // each repetition's time (the answer's, where there was no warm-up)
  long chosen = 0;              // the index in times_s of the answer
};

// run() solves once and returns its result; time(result) is the seconds that count (the slowest rank's is taken).
template <class Run, class Time>
auto repeat_for(double min_time_s, Run&& run, Time&& time, Repetitions& reps) -> decltype(run()) {
  using R = decltype(run());
  reps = Repetitions{};
  reps.min_time_s = min_time_s;
  R first = run();
  const double t0 = comm::max(time(first));
  if (min_time_s <= 0 || t0 >= min_time_s) {
    reps.times_s = {t0};
    return first;
  }
  reps.warmup_s = t0;
  std::vector<R> results;
  double sum = 0;
  while (sum < min_time_s && static_cast<long>(results.size()) < kMaxRepetitions) {
    results.push_back(run());
    reps.times_s.push_back(comm::max(time(results.back())));
    sum += reps.times_s.back();
  }
  std::vector<long> order(results.size());
  std::iota(order.begin(), order.end(), 0L);
  std::sort(order.begin(), order.end(), [&](long a, long b) { return reps.times_s[a] < reps.times_s[b]; });
  reps.chosen = order[(order.size() - 1) / 2];
  return std::move(results[reps.chosen]);
}

// The record's "repetitions" section (common/record.schema.json): written where --min-time was given.
inline nlohmann::json to_json(const Repetitions& r) {
  return {{"min_time_s", r.min_time_s},
          {"warmup_s", r.warmup_s < 0 ? nlohmann::json() : nlohmann::json(r.warmup_s)},
          {"count", r.times_s.size()},
          {"times_s", r.times_s},
          {"chosen", r.chosen}};
}

// The summary's words for them: "" for one run without warm-up.
inline std::string describe(const Repetitions& r) {
  if (r.warmup_s < 0) return "";
  char buf[160];
  std::snprintf(buf, sizeof buf, "the median of %zu solves in this process (--min-time %g; a warm-up solve first, %.3g s)",
                r.times_s.size(), r.min_time_s, r.warmup_s);
  return buf;
}

}  // namespace hpcgi
