// The one physical check of an answer (radiosity/solve/physical.hpp): B >= E within the answer's residual and
// rounding, finite; on a closed room of F_ij = 1/(n-1) (rows summing to 1) whose answer is E/(1-ρ).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "radiosity/solve/physical.hpp"
#include "radiosity/solve/solve.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

constexpr size_t kN = 21;

Problem room(double rho) {
  return closed_problem(kN, std::vector<Rgb>(kN, Rgb{rho, rho, rho}), std::vector<Rgb>(kN, Rgb{1, 1, 1}));
}

}  // namespace

TEST(Physical, AnAnswerAtOrAboveEWithinItsResidualPasses) {
  const Problem p = room(0.5);
  std::vector<Rgb> B(kN, Rgb{2, 2, 2});  // the exact answer
  EXPECT_EQ(check_physical(p.sys, B, Rgb{0, 0, 0}, 1e-6, Precision::double_).status, SolveStatus::converged);
  B[3][1] = 1 - 1e-7;  // below E by less than tol * ||e|| (1e-6 * sqrt(21))
  EXPECT_EQ(check_physical(p.sys, B, Rgb{0, 0, 0}, 1e-6, Precision::double_).status, SolveStatus::converged);
}

TEST(Physical, BBelowEBeyondItsResidualIsUnphysicalNamingPatchAndChannel) {
  const Problem p = room(0.5);
  std::vector<Rgb> B(kN, Rgb{2, 2, 2});
  B[7][2] = 0.5;  // B - E = -0.5
  const PhysicalCheck c = check_physical(p.sys, B, Rgb{1e-8, 1e-8, 1e-8}, 1e-6, Precision::single);
  EXPECT_EQ(c.status, SolveStatus::unphysical);
  EXPECT_NE(c.detail.find("B - E = -0.5 at patch 7, channel b"), std::string::npos) << c.detail;
  EXPECT_NE(c.detail.find("the light is amplified, not absorbed"), std::string::npos) << c.detail;
  B[7][2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(check_physical(p.sys, B, Rgb{0, 0, 0}, 1e-6, Precision::single).status, SolveStatus::nonfinite);
}

// ρ = 1.2: (I - ρF) B = E has the algebraic solution B = E/(1 - ρ) = -5, which BiCG-STAB finds; solve() refuses it
// as unphysical whatever the method found, and a result that had failed already keeps its own status.
TEST(Physical, SolveRefusesBiCGStabsNegativeSolutionOfAnAmplifyingRoom) {
  const Problem p = room(1.2);
  SolveConfig c;
  c.method = Method::bicgstab;
  c.precision = Precision::double_;
  c.tol = 1e-8;
  const SolveResult r = solve(p.sys, c);
  EXPECT_EQ(r.status, SolveStatus::unphysical) << r.detail;
  EXPECT_TRUE(failed(r.status));
  SolveResult broken;
  broken.status = SolveStatus::breakdown;
  broken.B = r.B;
  EXPECT_FALSE(require_physical(p.sys, broken, 1e-8, Precision::double_));
  EXPECT_EQ(broken.status, SolveStatus::breakdown);
}
