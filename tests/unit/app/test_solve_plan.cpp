// The plan (solve_plan.cpp): the one place a request is refused, before anything is read.
#include <string>

#include "common/errors.hpp"
#include "radiosity/app/solve_plan.hpp"
#include "tests/unit/app/solve_fixture.hpp"

using namespace radiosity;
using namespace radiosity::app;
using solve_phases::SolvePhases;

namespace {

// plan_solve(a) throws a UsageError whose message contains `part`.
void refused(const SolveArgs& a, const std::string& part) {
  try {
    plan_solve(a);
    ADD_FAILURE() << "not refused; expected: " << part;
  } catch (const hpcgi::UsageError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

}  // namespace

TEST_F(SolvePhases, PlanOfADefaultRequest) {
  args.threads = 2;
  args.size = "64x48";
  const SolvePlan p = plan_solve(args);
  EXPECT_EQ(p.cfg.threads, 2);
  EXPECT_EQ(p.backend->name, "openmp");
  EXPECT_EQ(p.width, 64);
  EXPECT_EQ(p.height, 48);
  EXPECT_EQ(p.values, FFValues::float32);
  EXPECT_FALSE(p.dist);
  EXPECT_EQ(p.limit, 0);
  EXPECT_FALSE(p.storage.has_value());  // auto
  args.storage = "compressed";
  args.ff_precision = "bfloat16";
  const SolvePlan q = plan_solve(args);
  EXPECT_EQ(q.storage, FFStorage::compressed);
  EXPECT_EQ(q.values, FFValues::bfloat16);
}

TEST_F(SolvePhases, PlanRefusesWhatCannotRun) {
  SolveArgs a = args;
  a.size = "64by48";
  refused(a, "--size must be WIDTHxHEIGHT");
  a = args;
  a.cfg.backend = "gpu";
  refused(a, "unknown solver backend 'gpu' (known: original | serial");
  a = args;
  a.cfg.method = Method::bicgstab;
  a.cfg.steps = 32;
  refused(a, "a fixed step count is for jacobi");  // the library's rule, applied by the plan before the load
  a = args;
  a.cfg.backend = "original";
  a.cfg.steps = 32;
  a.storage = "csr";
  refused(a, "backend 'original' does not read csr float32 form factors (serial, openmp, cuda, cublas, mpi do)");
  a = args;
  a.snapshots = {1, 1001};
  refused(a, "--snapshots 1001: no such iteration (the run has at most 1000)");
  a = args;
  a.output_xml = a.ff;
  refused(a, "--output");
}

TEST_F(SolvePhases, PlanRefusesABackendThisBuildLacks) {
  const SolveBackend* lacking = nullptr;
  for (const SolveBackend& b : solve_backends())
    if (!b.built) lacking = &b;
  if (!lacking) GTEST_SKIP() << "this build has every backend";
  args.cfg.backend = lacking->name;
  refused(args, "solver backend '" + lacking->name + "' is not available: " + lacking->why_not);
}

TEST_F(SolvePhases, PlanOfASparseFile) {
  FormFactorFileInfo info;
  info.version = 2;
  info.storage = "csr";
  info.precision = "float32";
  EXPECT_NO_THROW(plan_sparse_file(plan_solve(args), info));
  args.storage = "compressed";
  EXPECT_THROW(plan_sparse_file(plan_solve(args), info), hpcgi::UsageError);
  args.storage = "auto";
  args.ff_precision = "float16";
  EXPECT_THROW(plan_sparse_file(plan_solve(args), info), hpcgi::UsageError);
  args.ff_precision = "float32";
  args.threshold = 0.01;
  EXPECT_THROW(plan_sparse_file(plan_solve(args), info), hpcgi::UsageError);
}

TEST_F(SolvePhases, SnapshotFileNames) {
  EXPECT_EQ(snapshot_file("", 4), "snapshot_iter4.png");
  EXPECT_EQ(snapshot_file("out/room", 32), "out/room_iter32.png");
  args.snapshots = {1, 2};
  const SolvePlan p = plan_solve(args);
  ASSERT_EQ(p.snapshots.size(), 2u);
  EXPECT_EQ(p.snapshots[1], (std::pair<long, std::string>{2, "snapshot_iter2.png"}));
}
