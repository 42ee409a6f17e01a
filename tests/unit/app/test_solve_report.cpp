// The report (solve_report.cpp): the record's fields as analysis/ reads them.
#include <string>
#include <utility>

#include "radiosity/app/solve_report.hpp"
#include "tests/unit/app/solve_fixture.hpp"

using namespace radiosity;
using namespace radiosity::app;
using solve_phases::SolvePhases;

namespace {

class SolveRecord : public SolvePhases {
 protected:
  nlohmann::json record() {
    const auto s = solved();
    const Checked c = verify_solve(s->p, s->L, std::move(s->R), s->run.res);
    return solve_record(SolveReport{s->p, s->L, s->run, c, 1.5});
  }
};

}  // namespace

TEST_F(SolveRecord, RecordOfAVerifiedRun) {
  args.storage = "csr";
  const nlohmann::json rec = record();
  const nlohmann::json& params = rec.at("params");
  EXPECT_EQ(params.at("command"), "solve");
  EXPECT_EQ(params.at("patches"), 4);
  EXPECT_EQ(params.at("storage"), "csr");
  EXPECT_EQ(params.at("storage_requested"), "csr");
  EXPECT_EQ(params.at("ff_precision"), "float32");
  EXPECT_EQ(params.at("hemicube"), 32);
  EXPECT_TRUE(params.at("omega").is_null());
  EXPECT_TRUE(params.at("fused").is_null());
  EXPECT_EQ(params.at("tol"), 1e-6);
  const nlohmann::json& result = rec.at("result");
  EXPECT_EQ(result.at("status"), "converged");
  EXPECT_EQ(result.at("kept"), 4);  // the squares' rows that reflect: each sees the two of the other square
  EXPECT_EQ(result.at("skipped_rows"), 2);
  EXPECT_TRUE(result.at("error_vs_reference").is_number());
  EXPECT_EQ(result.at("reference").at("patches"), 4);
  EXPECT_EQ(rec.at("verify").at("agreed"), true);
  EXPECT_EQ(rec.at("times_s").at("total"), 1.5);
  EXPECT_EQ(rec.at("perf").at("timer"), "host wall clock");
  EXPECT_FALSE(rec.contains("mpi"));
}

TEST_F(SolveRecord, RecordWithoutVerifyAndWithHistory) {
  args.verify = false;
  args.cfg.history = true;
  args.cfg.steps = 4;
  const nlohmann::json rec = record();
  EXPECT_TRUE(rec.at("result").at("error_vs_reference").is_null());
  EXPECT_FALSE(rec.at("result").contains("reference"));
  EXPECT_TRUE(rec.at("verify").at("agreed").is_null());
  EXPECT_TRUE(rec.at("params").at("tol").is_null());
  const nlohmann::json& h = rec.at("result").at("history");
  EXPECT_EQ(h.at("rule"), "residual-e");
  EXPECT_EQ(h.at("iteration").size(), h.at("res2").size());
  EXPECT_EQ(h.at("iteration").back(), 4);
  EXPECT_EQ(h.at("rel_residual_e").back().size(), 3u);
  EXPECT_TRUE(h.at("rel_residual_e_stacked").back().is_number());
}
