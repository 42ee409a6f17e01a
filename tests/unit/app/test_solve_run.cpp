// The solve (solve_run.cpp): the plan's backend and method on the loaded system, with its snapshots.
#include <filesystem>

#include "radiosity/app/solve_run.hpp"
#include "tests/unit/app/solve_fixture.hpp"

using namespace radiosity;
using namespace radiosity::app;
using solve_phases::SolvePhases;

TEST_F(SolvePhases, RunsThePlansMethodAndDrawsSnapshots) {
  args.cfg.method = Method::bicgstab;
  args.snapshots = {1, 2};
  args.snapshot_prefix = file("snap");
  args.size = "16x12";
  args.exposure = 2;
  const auto s = solved();
  const SolveRun& run = s->run;
  EXPECT_EQ(run.res.status, SolveStatus::converged);
  EXPECT_EQ(run.res.B.size(), 4u);
  EXPECT_EQ(run.ropt.exposure, 2);
  ASSERT_EQ(run.snapshot_files.size(), std::min<size_t>(2, size_t(run.res.iterations)));
  for (const std::string& f : run.snapshot_files) EXPECT_TRUE(std::filesystem::exists(f)) << f;
}

TEST_F(SolvePhases, FixedStepsRunExactlyThem) {
  args.cfg.steps = 3;
  const auto s = solved();
  const SolveRun& run = s->run;
  EXPECT_EQ(run.res.status, SolveStatus::steps_done);
  EXPECT_EQ(run.res.iterations, 3);
}
