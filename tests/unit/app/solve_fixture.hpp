// The phases of `bin/radiosity solve` (radiosity/app/solve_*.cpp) on a scene small enough to solve in a test: RRV's
// two facing squares (radiosity/scenes/facing_squares.xml, 4 patches), their form factors computed here into a
// file in a fresh folder.
#pragma once
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <utility>

#include "radiosity/app/commands.hpp"
#include "radiosity/app/solve_run.hpp"
#include "radiosity/app/solve_verify.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/hemicube.hpp"
#include "radiosity/scene/rrv_reader.hpp"
#include "tests/unit/scene/scene_test_util.hpp"

namespace solve_phases {

class SolvePhases : public ::testing::Test {
 protected:
  void SetUp() override {
    args.scene = scene_test::own_scene("facing_squares.xml");
    args.ff = (tmp.path() / "squares.ff").string();
    args.quiet = true;
    radiosity::HemicubeParams hp;
    hp.resolution = 32;
    const radiosity::Mesh m = radiosity::load_rrv_scene(args.scene, args.load);
    radiosity::save_form_factors(args.ff, m, radiosity::compute_form_factors(m, hp));
  }
  std::string file(const std::string& name) const { return (tmp.path() / name).string(); }

  // The phases up to the solve (plan, load with the error reference's phase between its steps, solve) on args, in
  // run_solve's order.
  struct Solved {
    radiosity::app::SolvePlan p;
    radiosity::app::Loaded L;
    radiosity::app::References R;
    radiosity::app::SolveRun run;
  };
  std::unique_ptr<Solved> solved() const {
    using namespace radiosity::app;
    auto s = std::make_unique<Solved>();
    s->p = plan_solve(args);
    Loaded mesh = load_mesh(s->p);
    solve_reference_at(ReferencePoint::before_form_factors, s->p, mesh, s->R);
    Loaded read = read_form_factors(s->p, std::move(mesh));
    solve_reference_at(ReferencePoint::before_rounding, s->p, read, s->R);
    s->L = build_matrix(s->p, std::move(read));
    s->run = run_solver(s->p, s->L);
    return s;
  }

  scene_test::TempDir tmp;
  radiosity::app::SolveArgs args;
};

}  // namespace solve_phases
