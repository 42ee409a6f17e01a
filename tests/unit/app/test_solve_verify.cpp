// The verification (solve_verify.cpp): the float64 check, the error reference and the outcome of a run.
#include <string>
#include <utility>

#include "radiosity/app/solve_run.hpp"
#include "radiosity/app/solve_verify.hpp"
#include "tests/unit/app/solve_fixture.hpp"

using namespace radiosity;
using namespace radiosity::app;
using solve_phases::SolvePhases;

TEST_F(SolvePhases, ConvergedRunAgreesWithItsReference) {
  args.cfg.tol = 1e-8;
  const auto s = solved();
  const Checked c = verify_solve(s->p, s->L, std::move(s->R), s->run.res);
  ASSERT_TRUE(c.made);
  EXPECT_TRUE(c.v.agreed);
  EXPECT_LE(c.v.max_rel_diff, c.v.bound);
  EXPECT_NEAR(c.v.bound, 1e-5 + 20 * 1e-8, 1e-12);
  EXPECT_EQ(c.outcome.status, hpcgi::kExitOk);
  EXPECT_TRUE(c.ref.converged);
  EXPECT_EQ(c.ref.of, args.ff + " (4 patches)");  // the run's own matrix
  EXPECT_LT(c.error, 1e-5);
}

TEST_F(SolvePhases, NoVerifyMakesNoCheck) {
  args.verify = false;
  const auto s = solved();
  EXPECT_FALSE(s->R.have);
  const Checked c = verify_solve(s->p, s->L, std::move(s->R), s->run.res);
  EXPECT_FALSE(c.made);
  EXPECT_EQ(c.ref.B.size(), 0u);
  EXPECT_EQ(c.outcome.status, hpcgi::kExitOk);
}

TEST(SolveOutcome, EachStatusItsExit) {
  SolveConfig cfg;
  SolveResult res;
  res.rel_residual = {1.0, 0.5, 0.25};
  res.status = SolveStatus::stagnant;
  res.detail = "no solution: the residual stopped";
  hpcgi::Outcome o = outcome_of(res, cfg, nullptr);
  EXPECT_EQ(o.status, hpcgi::kExitNumerical);
  EXPECT_EQ(o.reason, res.detail);
  res.status = SolveStatus::nonfinite;
  res.detail = "NaN in B";
  EXPECT_EQ(outcome_of(res, cfg, nullptr).reason, "nonfinite: NaN in B");
  res.status = SolveStatus::max_iter;
  o = outcome_of(res, cfg, nullptr);
  EXPECT_EQ(o.status, hpcgi::kExitNotConverged);
  EXPECT_NE(o.reason.find("jacobi stopped at --max-iter 1000 with the largest relative residual 1.000e+00"),
            std::string::npos) << o.reason;
  res.status = SolveStatus::converged;
  Verification v;
  v.max_rel_diff = 1e-3;
  v.bound = 1e-5;
  EXPECT_EQ(outcome_of(res, cfg, &v).status, hpcgi::kExitDisagreed);
  v.agreed = true;
  EXPECT_EQ(outcome_of(res, cfg, &v).status, hpcgi::kExitOk);
  EXPECT_EQ(outcome_of(res, cfg, nullptr).status, hpcgi::kExitOk);
}
