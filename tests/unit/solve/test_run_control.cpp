// How a run starts, counts, reports and stops: fixed steps, snapshots, statuses, refused configurations.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/solve/solve.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

SolveConfig config(const std::string& backend, const std::string& method, long steps) {
  SolveConfig c;
  c.backend = backend;
  c.method = parse_method(method);
  c.steps = steps;
  c.threads = 2;
  return c;
}

}  // namespace

TEST(RunControl, FixedStepsRunExactlyThatManyAndCallBackEachOne) {
  const Problem p = random_problem(60, 51);
  for (const char* backend : {"original", "serial", "openmp"})
    for (long steps : {1, 5, 32}) {
      SCOPED_TRACE(std::string(backend) + " " + std::to_string(steps));
      std::vector<long> seen;
      const SolveResult r =
          solve(p.sys, config(backend, "jacobi", steps), [&](long it, const std::vector<Rgb>&) { seen.push_back(it); });
      EXPECT_EQ(r.status, SolveStatus::steps_done);
      EXPECT_EQ(r.iterations, steps);
      EXPECT_EQ(r.matrix_passes, steps);
      ASSERT_EQ(long(seen.size()), steps);
      for (long k = 0; k < steps; ++k) EXPECT_EQ(seen[k], k + 1);
    }
}

// The snapshot after iteration k (report Figure 4.2) is the B a run of k steps ends with.
TEST(RunControl, SnapshotAfterKStepsIsTheResultOfKSteps) {
  const Problem p = random_problem(60, 53);
  for (const char* backend : {"original", "serial", "openmp"}) {
    SCOPED_TRACE(backend);
    std::vector<std::vector<Rgb>> snap;
    solve(p.sys, config(backend, "jacobi", 8), [&](long, const std::vector<Rgb>& B) { snap.push_back(B); });
    for (long k : {1, 2, 4, 8}) EXPECT_EQ(snap[k - 1], solve(p.sys, config(backend, "jacobi", k)).B) << k;
    EXPECT_NE(snap[0], snap[1]);
  }
}

TEST(RunControl, ToleranceRunsCallBackEveryIterationAndStopAtTheFirstThatMeetsIt) {
  const Problem p = random_problem(60, 55);
  for (const char* method : {"jacobi", "bicgstab"}) {
    SCOPED_TRACE(method);
    SolveConfig c = config("serial", method, 0);
    c.precision = Precision::double_;
    c.tol = 1e-9;
    long calls = 0;
    const SolveResult r = solve(p.sys, c, [&](long, const std::vector<Rgb>&) { ++calls; });
    ASSERT_EQ(r.status, SolveStatus::converged);
    EXPECT_EQ(calls, r.iterations);  // Jacobi's extra step that proved b_k converged returns b_k, not itself
    c.max_iter = r.iterations - 1;  // one iteration fewer is not enough
    const SolveResult short_run = solve(p.sys, c);
    EXPECT_EQ(short_run.status, SolveStatus::max_iter);
    EXPECT_EQ(short_run.iterations, r.iterations - 1);
    EXPECT_GT(std::max({short_run.rel_residual[0], short_run.rel_residual[1], short_run.rel_residual[2]}), 1e-9);
  }
}

// ρ near 0.9 and row sums near 1: Jacobi contracts by only ~0.89 a step; BiCG-STAB removes the slow mode at once.
TEST(RunControl, BicgstabNeedsFewerIterationsThanJacobiForRhoNearOne) {
  const Problem p = random_problem(100, 57, 0.88, 0.9, 0.995);
  SolveConfig c = config("serial", "jacobi", 0);
  c.precision = Precision::double_;
  c.tol = 1e-8;
  const SolveResult j = solve(p.sys, c);
  c.method = Method::bicgstab;
  const SolveResult b = solve(p.sys, c);
  ASSERT_EQ(j.status, SolveStatus::converged);
  ASSERT_EQ(b.status, SolveStatus::converged);
  EXPECT_LT(b.iterations, j.iterations);
  EXPECT_LT(b.matrix_passes, j.matrix_passes);  // also in work: two products an iteration
  RecordProperty("jacobi_iterations", int(j.iterations));
  RecordProperty("bicgstab_iterations", int(b.iterations));
}

TEST(RunControl, NanInEmissionEndsNonfiniteNotInAnEndlessLoop) {
  Problem p = random_problem(40, 59);
  p.sys.emission[7][1] = std::numeric_limits<double>::quiet_NaN();
  for (const char* backend : {"serial", "openmp"})
    for (const char* method : {"jacobi", "bicgstab"})
      for (const char* precision : {"float", "double"}) {
        SCOPED_TRACE(std::string(backend) + " " + method + " " + precision);
        SolveConfig c = config(backend, method, 0);
        c.precision = parse_precision(precision);
        c.max_iter = 1000000000;
        const SolveResult r = solve(p.sys, c);
        EXPECT_EQ(r.status, SolveStatus::nonfinite);
        EXPECT_LE(r.iterations, 1);
        EXPECT_FALSE(r.detail.empty());
      }
  for (const char* backend : {"original", "serial"}) {
    SCOPED_TRACE(backend);
    EXPECT_EQ(solve(p.sys, config(backend, "jacobi", 32)).status, SolveStatus::nonfinite);
  }
}

// A = [[1, -2], [0, 1]] (ρ = 1, F_12 = 2: no form factor, but input) and r0 = (1, 1): r0·A r0 = 0, so BiCG-STAB's
// first α would divide by zero. It must say so, not return NaN.
TEST(RunControl, BicgstabReportsBreakdown) {
  std::vector<float> F = {0, 2, 0, 0};
  System s;
  s.n = 2;
  s.matrix = dense_float32_view(F.data(), s.n);
  s.emission = {{1, 1, 1}, {1, 1, 1}};
  s.reflectivity = {{1, 1, 1}, {1, 1, 1}};
  s.initial = {{0, 0, 0}, {0, 0, 0}};
  SolveConfig c = config("serial", "bicgstab", 0);
  c.precision = Precision::double_;
  const SolveResult r = solve(s, c);
  EXPECT_EQ(r.status, SolveStatus::breakdown);
  EXPECT_NE(r.detail.find("r^.v"), std::string::npos) << r.detail;
  EXPECT_TRUE(std::isfinite(r.B[0][0]));
}

TEST(RunControl, UnsupportedCombinationsAreRefused) {
  const Problem p = random_problem(10, 61);
  auto refused = [&](SolveConfig c, const std::string& words) {
    try {
      solve(p.sys, c);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const hpcgi::UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  SolveConfig c = config("original", "jacobi", 32);
  c.method = Method::bicgstab;
  refused(c, "does not run method 'bicgstab'");
  c = config("original", "jacobi", 32);
  c.layout = Layout::soa;
  refused(c, "does not run layout 'soa'");
  c = config("original", "jacobi", 32);
  c.precision = Precision::double_;
  refused(c, "does not run precision 'double'");
  refused(config("original", "jacobi", 0), "fixed number of steps");
  refused(config("serial", "bicgstab", 32), "fixed step count is for jacobi");
  refused(config("cuda-aos", "jacobi", 32), "unknown solver backend 'cuda-aos'");
  // An unknown name never reaches a SolveConfig: its parse refuses it, with the names there are.
  auto unknown = [](auto parse, const std::string& name, const std::string& words) {
    try {
      parse(name);
      ADD_FAILURE() << "accepted: " << name;
    } catch (const hpcgi::UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  unknown(parse_method, "conjugate-gradient",
          "unknown method 'conjugate-gradient' (known: jacobi, bicgstab, gauss-seidel, sor)");
  unknown(parse_layout, "aosoa", "unknown layout 'aosoa' (known: aos, soa)");
  unknown(parse_precision, "half", "unknown precision 'half' (known: float, double)");
  unknown(parse_start, "ones", "unknown start 'ones' (known: rrv, zero, emission)");
  unknown(parse_channels, "2", "unknown channels '2' (known: auto, 3)");
  for (const auto& name : choice_names<Method>()) EXPECT_EQ(to_string(parse_method(name)), name);
  for (const auto& name : choice_names<Precision>()) EXPECT_EQ(to_string(parse_precision(name)), name);
  c = config("serial", "jacobi", 0);
  c.tol = 1;
  refused(c, "below 1");
  c.precision = Precision::single;
  c.tol = 1e-300;
  refused(c, "below what float can reach");
  c = config("serial", "jacobi", 0);
  c.tol = 0;
  refused(c, "tol");
  c = config("serial", "jacobi", 0);
  c.max_iter = 0;
  refused(c, "max_iter");
  refused(config("serial", "jacobi", -1), "steps");
  c = config("serial", "jacobi", 32);
  c.ff_threshold = 1e-3f;
  refused(c, "ff_threshold");
  c = config("openmp", "jacobi", 32);
  c.threads = -1;
  refused(c, "threads");
}

TEST(RunControl, BadSystemsAreRefused) {
  Problem p = random_problem(10, 63);
  p.sys.reflectivity.pop_back();
  EXPECT_THROW(solve(p.sys, config("serial", "jacobi", 1)), hpcgi::UsageError);
  System empty;
  EXPECT_THROW(solve(empty, config("serial", "jacobi", 1)), hpcgi::UsageError);
  Problem q = random_problem(10, 63);
  q.sys.matrix = FFMatrixView{};
  EXPECT_THROW(solve(q.sys, config("serial", "jacobi", 1)), hpcgi::UsageError);
}

TEST(RunControl, RrvStartsFromTheLargerOfAttributeAndEmission) {
  const std::vector<Rgb> attribute = {{0.2, 0.0, 5.0}, {0, 0, 0}};
  const std::vector<Rgb> emission = {{1.0, 0.0, 1.0}, {0, 0.3, 0}};
  const std::vector<Rgb> expected = {{1.0, 0.0, 5.0}, {0, 0.3, 0}};
  EXPECT_EQ(rrv_initial_radiosity(attribute, emission), expected);
  EXPECT_THROW(rrv_initial_radiosity(attribute, {{1, 1, 1}}), hpcgi::UsageError);

  Mesh mesh;
  mesh.patches.resize(2);
  for (int i = 0; i < 2; ++i) {
    mesh.patches[i].radiosity = attribute[i];
    mesh.patches[i].emission = emission[i];
    mesh.patches[i].reflectivity = {0.5, 0.5, 0.5};
  }
  const std::vector<float> F = {0, 0.5f, 0.5f, 0};
  const System s = make_system(mesh, F.data());
  EXPECT_EQ(s.n, 2u);
  EXPECT_EQ(s.initial, expected);
  EXPECT_EQ(s.emission, emission);
  EXPECT_EQ(s.reflectivity[1], (Rgb{0.5, 0.5, 0.5}));
}

TEST(RunControl, StatusNames) {
  EXPECT_STREQ(to_string(SolveStatus::converged), "converged");
  EXPECT_STREQ(to_string(SolveStatus::max_iter), "max_iter");
  EXPECT_STREQ(to_string(SolveStatus::steps_done), "steps_done");
  EXPECT_STREQ(to_string(SolveStatus::breakdown), "breakdown");
  EXPECT_STREQ(to_string(SolveStatus::nonfinite), "nonfinite");
  EXPECT_STREQ(to_string(SolveStatus::stagnant), "stagnant");
}
