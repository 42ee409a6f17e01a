// A grey system (r = g = b in every emission, reflectivity and starting radiosity) is three copies of one solve:
// the CPU backends solve it once and say so (SolveResult::channels), with the answer of the three-channel solve.
#include <gtest/gtest.h>

#include <string>

#include "radiosity/solve/solve.hpp"
#include "configs.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

// random_problem with channel 0 copied into channels 1 and 2.
Problem grey_problem(size_t n, unsigned seed) {
  Problem p = random_problem(n, seed);
  for (auto* v : {&p.sys.emission, &p.sys.reflectivity, &p.sys.initial})
    for (Rgb& x : *v) x[1] = x[2] = x[0];
  return p;
}

}  // namespace

TEST(Grey, GreySystemsSolveOneChannelWithTheAnswerOfThree) {
  const Problem p = grey_problem(203, 71);
  ASSERT_TRUE(is_grey(p.sys));
  for (const char* backend : {"serial", "openmp"})
    for (const char* layout : {"aos", "soa"})
      for (const char* precision : {"float", "double"})
        for (const auto& [method, steps] : {std::pair{"jacobi", 24L}, {"jacobi", 0L}, {"bicgstab", 0L}}) {
          SCOPED_TRACE(std::string(backend) + " " + layout + " " + precision + " " + method + " " +
                       std::to_string(steps));
          SolveConfig c = solve_config(backend, layout, method, precision, steps, 3);
          const SolveResult one = solve(p.sys, c);
          c.channels = Channels::three;
          const SolveResult three = solve(p.sys, c);
          EXPECT_EQ(one.channels, 1);
          EXPECT_EQ(three.channels, 3);
          EXPECT_EQ(one.status, three.status);
          EXPECT_EQ(one.iterations, three.iterations);
          EXPECT_LE(rel_diff(one.B, three.B), std::string(precision) == "float" ? 1e-6 : 1e-13);
          EXPECT_EQ(one.rel_residual[0], one.rel_residual[2]);
          for (const Rgb& b : one.B) EXPECT_TRUE(b[0] == b[1] && b[1] == b[2]);
        }
}

TEST(Grey, ColouredOrPartlyGreySystemsSolveThreeChannels) {
  const Problem coloured = random_problem(50, 73);
  EXPECT_FALSE(is_grey(coloured.sys));
  SolveConfig c;
  c.steps = 4;
  EXPECT_EQ(solve(coloured.sys, c).channels, 3);
  Problem start = grey_problem(50, 75);  // grey light and surfaces, a coloured starting radiosity
  start.sys.initial[7][1] += 0.25;
  EXPECT_FALSE(is_grey(start.sys));
  EXPECT_EQ(solve(start.sys, c).channels, 3);
  const Problem grey = grey_problem(50, 77);
  c.backend = "original";  // RRV's loop keeps its Color records
  EXPECT_EQ(solve(grey.sys, c).channels, 3);
}
