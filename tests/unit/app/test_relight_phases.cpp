// The phases of `bin/radiosity relight` (radiosity/app/relight_*.cpp) on RRV-format facing squares (one light, one
// reflector): the plan's refusals, the load, frames served from the basis against a cold float64 solve, a solved
// frame that stops at --max-iter (exit status 4), a frame with no solution (3), and the record's tallies against the frames served.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "common/errors.hpp"
#include "radiosity/app/relight_phases.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/hemicube.hpp"
#include "radiosity/relight/basis_file.hpp"
#include "radiosity/scene/rrv_reader.hpp"
#include "tests/unit/scene/scene_test_util.hpp"

using namespace radiosity;
using namespace radiosity::app;

namespace {

class RelightPhases : public ::testing::Test {
 protected:
  void SetUp() override {
    args.scene = scene_test::own_scene("facing_squares.xml");
    args.ff = (tmp.path() / "squares.ff").string();
    args.quiet = true;
    args.check_every = 1;
    HemicubeParams hp;
    hp.resolution = 32;
    const Mesh m = load_rrv_scene(args.scene, args.load);
    save_form_factors(args.ff, m, compute_form_factors(m, hp));
  }
  // plan, load, the basis and the frames served.
  ServedFrames serve(RelightInputs& in) {
    const RelightPlan p = plan_relight(args);
    load_relight(args, p, in);
    relight::BasisOptions bopt;
    bopt.tol = args.basis_tol;
    bool loaded = false;
    basis = relight::load_or_solve_basis("", in.m, in.ff_file, in.basis_view, in.lights, bopt, &loaded);
    return serve_frames(args, p, in, basis);
  }
  std::string frames_file(const std::string& json) {
    const std::string path = (tmp.path() / "frames.json").string();
    std::ofstream(path) << json;
    return path;
  }
  scene_test::TempDir tmp;
  RelightArgs args;
  relight::LightBasis basis;
};

TEST_F(RelightPhases, PlanRefusesBeforeAnythingIsRead) {
  args.size = "0x10";
  EXPECT_THROW(plan_relight(args), hpcgi::UsageError);
  args.size = "400x300";
  args.cfg.backend = "no-such-backend";
  EXPECT_THROW(plan_relight(args), hpcgi::UsageError);
  args.cfg.backend = "openmp";
  const RelightPlan p = plan_relight(args);
  EXPECT_EQ(p.width, 400);
  EXPECT_EQ(p.height, 300);
  EXPECT_EQ(p.values, FFValues::float32);
  EXPECT_FALSE(p.storage.has_value());  // auto
  args.storage = "diagonal";
  EXPECT_THROW(plan_relight(args), hpcgi::UsageError);
  args.storage = "runs";
  EXPECT_EQ(plan_relight(args).storage, FFStorage::runs);
  args.cfg.backend = "original";  // reads dense float32 only
  EXPECT_THROW(plan_relight(args), hpcgi::UsageError);
}

// --storage runs with F in float16: the frames read runs float16, the light basis runs float32, the frames agree with
// a cold float64 solve as dense's do.
TEST_F(RelightPhases, RunsStorageServesTheFramesAsDense) {
  args.storage = "runs";
  args.ff_precision = "float16";
  const Mesh m = load_rrv_scene(args.scene, args.load);
  const auto named = relight::named_entities(m);
  // the reflector darker, then the light made reflective too (its rows held even where the scene gives it 0)
  args.frames = frames_file(R"({"frames": [{}, {"reflectivity": {")" + named.back().name +
                            R"(": [0.3, 0.3, 0.3]}}, {"reflectivity": {")" + named.front().name +
                            R"(": [0.5, 0.5, 0.5]}}]})");
  RelightInputs in;
  const ServedFrames s = serve(in);
  EXPECT_EQ(in.storage, FFStorage::runs);
  EXPECT_EQ(in.frame_view.storage, FFStorage::runs);
  EXPECT_EQ(in.frame_view.values, FFValues::float16);
  EXPECT_EQ(in.basis_view.storage, FFStorage::runs);
  EXPECT_EQ(in.basis_view.values, FFValues::float32);
  EXPECT_EQ(s.solved, 2);
  EXPECT_EQ(s.checked, 3);
  EXPECT_LT(s.worst_error, 1e-3);
}

TEST_F(RelightPhases, BasisFramesAgreeWithAColdFloat64Solve) {
  args.random_frames = 4;
  RelightInputs in;
  const ServedFrames s = serve(in);
  ASSERT_EQ(in.m.size(), 4u);
  ASSERT_EQ(in.lights.size(), 1u);
  EXPECT_EQ(s.basis_ms.size(), 4u);
  EXPECT_EQ(s.solved, 0);
  EXPECT_EQ(s.checked, 4);
  EXPECT_LT(s.worst_error, 1e-5);
  EXPECT_EQ(s.outcome.status, hpcgi::kExitOk);
  nlohmann::json rec = {{"params", nlohmann::json::object()}};
  relight_record(rec, args, in, basis, false, s, 1.0);
  EXPECT_EQ(rec["result"]["frames"], 4);
  EXPECT_EQ(rec["result"]["latency_basis"]["count"], 4);
  EXPECT_EQ(rec["result"]["per_frame"].size(), 4u);
  EXPECT_EQ(rec["result"]["lights"], nlohmann::json::array({in.lights[0].name}));
}

TEST_F(RelightPhases, ASolvedFrameConvergesWarmOrStopsAtMaxIterWithStatus4) {
  const Mesh m = load_rrv_scene(args.scene, args.load);
  const std::string reflector = relight::named_entities(m).back().name;
  args.frames = frames_file(R"({"frames": [{"reflectivity": {")" + reflector + R"(": [0.25, 0.25, 0.25]}}]})");
  args.cfg.tol = 1e-7;
  {
    RelightInputs in;
    const ServedFrames s = serve(in);
    EXPECT_EQ(s.solved, 1);
    EXPECT_EQ(s.per_frame[0]["kind"], "solved");
    EXPECT_LT(s.worst_residual, 1e-7);
    EXPECT_LT(s.worst_error, 1e-5);
    EXPECT_EQ(s.outcome.status, hpcgi::kExitOk);
  }
  args.cfg.tol = 1e-8;  // reachable in float (check_config refuses a tolerance below its rounding), not in one step
  args.cfg.max_iter = 1;
  RelightInputs in;
  const ServedFrames s = serve(in);
  EXPECT_EQ(s.outcome.status, hpcgi::kExitNotConverged);
  EXPECT_NE(s.outcome.reason.find("frame 0"), std::string::npos) << s.outcome.reason;
  EXPECT_EQ(s.over_tol, 1);
}

// The closed box made lossless (reflectivity 1, every face emitting): (I - F) B = E has no solution. The frame ends
// with exit status 3, the frames stop there, and what was served is still there for the record.
TEST_F(RelightPhases, AFrameWithNoSolutionStopsTheFramesWithStatus3) {
  args.scene = scene_test::own_scene("closed_box.xml");
  args.ff = (tmp.path() / "box.ff").string();
  args.load.allow_reflectivity_ge_1 = true;
  HemicubeParams hp;
  hp.resolution = 32;
  const Mesh m = load_rrv_scene(args.scene, args.load);
  save_form_factors(args.ff, m, compute_form_factors(m, hp));
  args.frames = frames_file(R"({"frames": [{"reflectivity": {"box.1": [1, 1, 1]}}, {}]})");
  args.cfg.tol = 1e-6;
  args.check_every = 0;
  RelightInputs in;
  const ServedFrames s = serve(in);
  EXPECT_EQ(s.outcome.status, hpcgi::kExitNumerical);
  EXPECT_NE(s.outcome.reason.find("no solution"), std::string::npos) << s.outcome.reason;
  ASSERT_EQ(s.per_frame.size(), 1u);
  EXPECT_EQ(s.per_frame[0]["status"], "stagnant");
}

}  // namespace
