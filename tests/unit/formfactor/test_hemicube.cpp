// The hemicube against references it does not compute itself (tests/unit/formfactor/references.hpp):
//  - Howell's closed forms for three configurations, as the area-weighted sum over many small patches;
//  - the exact centroid-to-patch form factors of the same mesh, which the hemicube must approach as R grows (this
//    separates the hemicube's own error from the mesh's: the centroid rule over finite patches);
//  - the closed cube, whose every row must sum to the whole hemicube's weight (1 exact, ~0.988 rrv2007).
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <functional>
#include <map>

#include "common/errors.hpp"
#include "radiosity/formfactor/diagnostics.hpp"
#include "radiosity/formfactor/hemicube.hpp"
#include "radiosity/scene/analytic.hpp"
#include "tests/unit/formfactor/references.hpp"

using namespace radiosity;
using namespace fftest;

namespace {

constexpr int kResolutions[] = {32, 64, 128, 256};

struct Configuration {
  const char* name;
  std::function<Mesh()> make;
  double closed_form;  // F from entity 0 to entity 1
};

// Small meshes (256 to 896 patches) keep the suite fast; their own discretisation errors are measured below.
const std::vector<Configuration>& configurations() {
  static const std::vector<Configuration> c = {
      {"facing squares", [] { return two_facing_squares(8); }, howell_parallel_rectangles(1, 1, 1)},
      {"perpendicular squares", [] { return perpendicular_squares(8); }, howell_perpendicular_rectangles(1, 1, 1)},
      {"coaxial disks", [] { return coaxial_disks(4, 64); }, howell_coaxial_disks(1, 1, 1)},
  };
  return c;
}

struct Computed {
  Mesh mesh;
  FormFactors limit;                 // exact centroid-to-patch form factors
  std::map<int, FormFactors> by_r;   // hemicube, exact weights
};

// Each configuration is computed once per resolution for all the tests that look at it.
const Computed& computed(size_t c) {
  static std::map<size_t, Computed> cache;
  auto it = cache.find(c);
  if (it != cache.end()) return it->second;
  Computed r;
  r.mesh = configurations()[c].make();
  r.limit = centroid_form_factors(r.mesh);
  for (int R : kResolutions) r.by_r[R] = compute_form_factors(r.mesh, {R, HemicubeWeights::exact, 0});
  return cache.emplace(c, std::move(r)).first->second;
}

double relative_error(double value, double reference) { return std::abs(value / reference - 1); }

// Σ |F_ij - L_ij| / Σ L_ij: how far, entry by entry, a matrix is from the centroid limit.
double entrywise_error(const FormFactors& F, const FormFactors& L) {
  double diff = 0, sum = 0;
  for (size_t k = 0; k < F.values.size(); ++k) {
    diff += std::abs(double(F.values[k]) - L.values[k]);
    sum += L.values[k];
  }
  return diff / sum;
}

}  // namespace

TEST(HemicubeWeights, ExactWeightsSumToOneWithMidpointError) {
  double previous = 0;
  for (int R : kResolutions) {
    const double error = std::abs(hemicube_weight_total({R, HemicubeWeights::exact, 0}) - 1);
    if (previous > 0) {
      EXPECT_NEAR(previous / error, 4.0, 0.3) << "O(1/R²) at R = " << R;
    }
    previous = error;
  }
  EXPECT_LT(previous, 1e-5);
}

// RRV's cos·cos weights integrate over the unfolded cross (the 2R × 2R square less its four R/2 × R/2 corners) to
// (2/3R²)·(4R/π)²·(1 - (1 - 1/√2)²) = 32/(3π²)·(1 - (1 - 1/√2)²) = 0.988054: FORMAT.md's "about 0.988".
TEST(HemicubeWeights, Rrv2007WeightsSumToRrvsTotal) {
  const double integral = 32 / (3 * M_PI * M_PI) * (1 - std::pow(1 - 1 / std::sqrt(2.0), 2));
  EXPECT_NEAR(integral, 0.988, 0.0005);
  EXPECT_NEAR(hemicube_weight_total({256, HemicubeWeights::rrv2007, 0}), integral, 2e-5);
}

class Configurations : public ::testing::TestWithParam<size_t> {};

// The task's criterion: within 1% of the closed form at the default R = 256, both ways.
TEST_P(Configurations, MatchClosedFormAtDefaultResolution) {
  const Configuration& c = configurations()[GetParam()];
  const Computed& d = computed(GetParam());
  EXPECT_LT(relative_error(entity_form_factor(d.mesh, d.by_r.at(256), 0, 1), c.closed_form), 0.01) << c.name;
  EXPECT_LT(relative_error(entity_form_factor(d.mesh, d.by_r.at(256), 1, 0), c.closed_form), 0.01) << c.name;
}

// The hemicube's own error, against the exact value for the same mesh, falls with R: from 0.002-1.5% at R = 32 to
// under 0.03% at R = 256 (measured: facing 1.46% -> 0.018%, perpendicular 0.32% -> 0.004%, disks 0.002% ->
// 0.0003%; not monotone in between, the aliasing of regular meshes comes and goes).
TEST_P(Configurations, HemicubeErrorFallsWithResolution) {
  const Configuration& c = configurations()[GetParam()];
  const Computed& d = computed(GetParam());
  const double limit = entity_form_factor(d.mesh, d.limit, 0, 1);
  const double coarse = relative_error(entity_form_factor(d.mesh, d.by_r.at(32), 0, 1), limit);
  const double fine = relative_error(entity_form_factor(d.mesh, d.by_r.at(256), 0, 1), limit);
  EXPECT_LT(fine, coarse) << c.name;
  EXPECT_LT(fine, 3e-4) << c.name;
}

// Against the closed form the error also falls with R until the mesh's own error (the centroid rule over 8 × 8
// cells: +0.16% facing, -0.04% perpendicular) is reached. For the disks the mesh's error (+0.067%: the inscribed
// polygons and the centroid rule) exceeds the hemicube's already at R = 32, so there the error against the closed
// form is flat in R and must equal the mesh's.
TEST_P(Configurations, ErrorAgainstClosedFormFallsToTheMeshError) {
  const Configuration& c = configurations()[GetParam()];
  const Computed& d = computed(GetParam());
  const double mesh_error = entity_form_factor(d.mesh, d.limit, 0, 1) / c.closed_form - 1;
  const double coarse = relative_error(entity_form_factor(d.mesh, d.by_r.at(32), 0, 1), c.closed_form);
  const double fine = entity_form_factor(d.mesh, d.by_r.at(256), 0, 1) / c.closed_form - 1;
  EXPECT_LT(std::abs(mesh_error), 0.002) << c.name;
  EXPECT_NEAR(fine, mesh_error, 3e-4) << c.name;  // what is left is the mesh's error
  if (std::abs(mesh_error) < coarse / 2) {
    EXPECT_LT(std::abs(fine), coarse) << c.name;
  }
}

// Entry by entry, F_ij approaches the exact form factor from centroid i to patch j: Σ|F - L| / ΣL falls at every
// doubling of R (measured 13-41% at R = 32, 1.4-2.4% at R = 256).
TEST_P(Configurations, EveryEntryConvergesToTheCentroidFormFactor) {
  const Configuration& c = configurations()[GetParam()];
  const Computed& d = computed(GetParam());
  double previous = 1e9;
  for (int R : kResolutions) {
    const double e = entrywise_error(d.by_r.at(R), d.limit);
    EXPECT_LT(e, previous) << c.name << " at R = " << R;
    previous = e;
  }
  EXPECT_LT(previous, 0.03) << c.name;
}

// Reciprocity A_1 F_12 = A_2 F_21 between the two surfaces.
TEST_P(Configurations, ReciprocityBetweenTheSurfaces) {
  const Computed& d = computed(GetParam());
  const FormFactors& F = d.by_r.at(256);
  const double a = entity_area(d.mesh, 0) * entity_form_factor(d.mesh, F, 0, 1);
  const double b = entity_area(d.mesh, 1) * entity_form_factor(d.mesh, F, 1, 0);
  EXPECT_LT(std::abs(a - b) / std::max(a, b), 0.005) << configurations()[GetParam()].name;
}

// Reciprocity patch by patch is only as good as the centroid rule allows (neighbouring patches of the
// perpendicular squares miss it by 25% even with exact centroid form factors). The hemicube's energy-weighted mean
// error must fall with R and come within 2 points of the centroid limit's (measured at R = 256: facing 1.5% vs
// 0.0%, perpendicular 5.5% vs 4.8%, disks 1.5% vs 0.1%).
TEST_P(Configurations, PairwiseReciprocityApproachesTheCentroidLimit) {
  const Configuration& c = configurations()[GetParam()];
  const Computed& d = computed(GetParam());
  const double limit = diagnose_form_factors(d.mesh, d.limit).mean_reciprocity_error;
  const double coarse = diagnose_form_factors(d.mesh, d.by_r.at(32)).mean_reciprocity_error;
  const double fine = diagnose_form_factors(d.mesh, d.by_r.at(256)).mean_reciprocity_error;
  EXPECT_LT(fine, coarse) << c.name;
  EXPECT_LT(fine, limit + 0.02) << c.name;
}

INSTANTIATE_TEST_SUITE_P(Hemicube, Configurations, ::testing::Range<size_t>(0, 3));

namespace {

// Every patch of a closed cube sees only other patches: its row sums to the whole hemicube's weight, exactly when
// no pixel is lost or counted twice.
void expect_rows_sum_to(const Mesh& cube, const HemicubeParams& p, double expected, double tolerance) {
  const FormFactors F = compute_form_factors(cube, p);
  const FormFactorDiagnostics d = diagnose_form_factors(cube, F);
  EXPECT_NEAR(d.min_row_sum, expected, tolerance) << "row " << d.min_row;
  EXPECT_NEAR(d.max_row_sum, expected, tolerance) << "row " << d.max_row;
  const double total = hemicube_weight_total(p);
  EXPECT_NEAR(d.min_row_sum, total, 1e-5) << "a pixel lost in row " << d.min_row;
  EXPECT_NEAR(d.max_row_sum, total, 1e-5) << "a pixel counted twice in row " << d.max_row;
}

}  // namespace

TEST(ClosedCube, RowsSumToOneWithExactWeights) {
  expect_rows_sum_to(closed_unit_cube(4, {0.5, 0.5, 0.5}, {0, 0, 0}), {256, HemicubeWeights::exact, 0}, 1.0, 0.005);
}

// With rrv2007 weights every row is RRV's hemicube total, 0.98804 at R = 256; the documented value 0.988 is that
// total to three digits (HemicubeWeights.Rrv2007WeightsSumToRrvsTotal), so the tolerance is its rounding, 5e-4.
TEST(ClosedCube, RowsSumToRrvsTotalWithRrv2007Weights) {
  expect_rows_sum_to(closed_unit_cube(4, {0.5, 0.5, 0.5}, {0, 0, 0}), {256, HemicubeWeights::rrv2007, 0}, 0.988,
                     5e-4);
}

// The same cube turned so that one face's normal is (1,2,3)/√14, where RRV's eye frame (side = n × (1,2,3)) breaks
// down and the fallback axis is used; no face is aligned with the pixel grid any more.
TEST(ClosedCube, RowsSumToOneInAnyOrientation) {
  Mesh cube = closed_unit_cube(3, {0.5, 0.5, 0.5}, {0, 0, 0});
  const Vec3 w = Vec3{1, 2, 3}.normalized(), a = Vec3{0, 0, 1}.cross(w).normalized(), b = w.cross(a);
  // The rotation taking the frame (a, b', z) to (a, b, w), with b' = z × a: the floor's normal z goes to w.
  const Vec3 bp = Vec3{0, 0, 1}.cross(a);
  for (Patch& p : cube.patches)
    for (Vec3& v : p.v) {
      const Vec3 q = v - Vec3{0.5, 0.5, 0.5};
      v = a * q.dot(a) + b * q.dot(bp) + w * q.z;
    }
  const size_t floor = 4 * 18;  // the first patch of face z0, whose inward normal was +z
  ASSERT_LT((cube.patches[floor].normal() - w).norm(), 1e-12);
  expect_rows_sum_to(cube, {128, HemicubeWeights::exact, 0}, 1.0, 0.005);
}

// Faces of the cube see each other with the closed forms' factors: opposite 0.199825, adjacent 0.200044 (with the
// 6 × 6 mesh's own centroid-rule error of about 0.3%).
TEST(ClosedCube, FaceToFaceFactorsMatchClosedForms) {
  const Mesh cube = closed_unit_cube(6, {0.5, 0.5, 0.5}, {0, 0, 0});
  const FormFactors F = compute_form_factors(cube, {256, HemicubeWeights::exact, 0});
  // Entities x0, x1, y0, y1, z0, z1: x0 faces x1 and is adjacent to the other four.
  EXPECT_LT(relative_error(entity_form_factor(cube, F, 0, 1), howell_parallel_rectangles(1, 1, 1)), 0.01);
  for (int e = 2; e < 6; ++e)
    EXPECT_LT(relative_error(entity_form_factor(cube, F, 0, e), howell_perpendicular_rectangles(1, 1, 1)), 0.01);
}

// A point under the centre of a unit square at height 1, the square turned to RRV's eye frame of that point (side
// = n × (1,2,3) = (-2,1,0)/√5, up = side × n) so that it covers exactly the middle half of the top face, pixel
// boundaries included. Exact weights give Howell's value, 4·B-3(1/2, 1/2, 1) = 0.2394. RRV's weights give their
// own integral over that region, (2/3R²)·(∫cos(πx/2R)dx over |x| <= R/4)² = 32/(3π²)·sin²(π/8) = 0.1583: RRV's
// form factors for what lies straight above a patch are a third too low (they favour the horizon instead, for a
// total of 0.988).
TEST(RrvWeights, OverheadSquareGetsRrvsIntegralNotTheExactValue) {
  const Vec3 n{0, 0, 1}, u = n.cross({1, 2, 3}).normalized(), v = u.cross(n), top{0.5, 0.5, 1};
  Mesh m;
  m.entities = {"point", "square"};
  Patch point;  // a tiny triangle whose centroid is (0.5, 0.5, 0)
  const double e = 1e-4;
  point.v = {Vec3{0.5 - e, 0.5 - e, 0}, Vec3{0.5 + 2 * e, 0.5 - e, 0}, Vec3{0.5 - e, 0.5 + 2 * e, 0}};
  m.patches.push_back(point);
  const Vec3 c[4] = {top - u * 0.5 - v * 0.5, top + u * 0.5 - v * 0.5, top + u * 0.5 + v * 0.5,
                     top - u * 0.5 + v * 0.5};
  for (const auto& tri : {std::array<Vec3, 3>{c[0], c[1], c[2]}, std::array<Vec3, 3>{c[0], c[2], c[3]}}) {
    Patch p;
    p.v = tri;
    p.entity = 1;
    m.patches.push_back(p);
  }
  ASSERT_NEAR(m.patches[1].normal().z, -1.0, 1e-12);  // facing down, towards the point
  auto seen = [&m](HemicubeWeights w) {
    const FormFactors F = compute_form_factors(m, {256, w, 0});
    return double(F(0, 1)) + F(0, 2);
  };
  EXPECT_NEAR(seen(HemicubeWeights::exact), 4 * howell_point_to_parallel_rectangle_corner(0.5, 0.5, 1), 2e-4);
  const double rrv_integral = 32 / (3 * M_PI * M_PI) * std::pow(std::sin(M_PI / 8), 2);
  EXPECT_NEAR(seen(HemicubeWeights::rrv2007), rrv_integral, 5e-4);
}

// A blocker between the facing squares hides square 2 from square 1 entirely; what square 1 sees of the blocker is
// the exact point-to-area value, and square 2 still sees the blocker's back (no back-face culling, as in RRV).
TEST(Occlusion, BlockerHidesTheSquareBehindIt) {
  Mesh m = two_facing_squares(4);
  m.entities.push_back("blocker");
  const Mesh blocker = two_facing_squares(2);  // its square 2 faces -z: towards square 1
  for (Patch p : blocker.patches) {
    if (p.entity != 1) continue;
    for (Vec3& v : p.v) v = Vec3{3 * v.x - 1, 3 * v.y - 1, 0.5};  // [-1, 2]² at z = 0.5
    p.entity = 2;
    m.patches.push_back(p);
  }
  const FormFactors F = compute_form_factors(m, {128, HemicubeWeights::exact, 0});
  EXPECT_EQ(entity_form_factor(m, F, 0, 1), 0.0);
  EXPECT_EQ(entity_form_factor(m, F, 1, 0), 0.0);
  const FormFactors L = centroid_form_factors(m);  // no occlusion between square 1 and the blocker
  EXPECT_LT(relative_error(entity_form_factor(m, F, 0, 2), entity_form_factor(m, L, 0, 2)), 0.002);
  EXPECT_LT(relative_error(entity_form_factor(m, F, 1, 2), entity_form_factor(m, L, 1, 2)), 0.002);
}

// Form factors do not depend on scale with exact weights; with rrv2007 weights RRV's far plane at 50 cuts away
// what lies farther.
TEST(Clipping, ScaleInvarianceAndRrvFarPlane) {
  const Mesh unit = two_facing_squares(4);
  Mesh far = unit;
  for (Patch& p : far.patches)
    for (Vec3& v : p.v) v = v * 60.0;
  const FormFactors a = compute_form_factors(unit, {64, HemicubeWeights::exact, 0});
  const FormFactors b = compute_form_factors(far, {64, HemicubeWeights::exact, 0});
  EXPECT_NEAR(entity_form_factor(far, b, 0, 1), entity_form_factor(unit, a, 0, 1), 1e-6);
  EXPECT_GT(entity_form_factor(unit, compute_form_factors(unit, {64, HemicubeWeights::rrv2007, 0}), 0, 1), 0.1);
  EXPECT_EQ(entity_form_factor(far, compute_form_factors(far, {64, HemicubeWeights::rrv2007, 0}), 0, 1), 0.0);
}

TEST(FormFactorMatrix, DiagonalZeroEntriesFiniteAndThresholdApplied) {
  const Mesh m = perpendicular_squares(4);
  const FormFactors all = compute_form_factors(m, {64, HemicubeWeights::exact, 0});
  const FormFactors kept = compute_form_factors(m, {64, HemicubeWeights::exact, 2e-3});
  ASSERT_EQ(all.n, m.size());
  ASSERT_EQ(all.values.size(), m.size() * m.size());
  EXPECT_EQ(kept.params.threshold, 2e-3);
  size_t dropped = 0;
  for (size_t i = 0; i < m.size(); ++i) {
    EXPECT_EQ(all(i, i), 0.0f);
    for (size_t j = 0; j < m.size(); ++j) {
      EXPECT_TRUE(std::isfinite(all(i, j)) && all(i, j) >= 0);
      if (all(i, j) > 2e-3) {
        EXPECT_EQ(kept(i, j), all(i, j));
      } else {
        EXPECT_EQ(kept(i, j), 0.0f);
        dropped += all(i, j) > 0;
      }
    }
  }
  EXPECT_GT(dropped, 0u);
}

TEST(FormFactorMatrix, DegeneratePatchSendsAndReceivesNothing) {
  Mesh m = two_facing_squares(2);
  Patch flat = m.patches[0];
  flat.v[2] = flat.v[1];
  m.patches.push_back(flat);
  const FormFactors F = compute_form_factors(m, {32, HemicubeWeights::exact, 0});
  const size_t d = m.size() - 1;
  for (size_t j = 0; j < m.size(); ++j) {
    EXPECT_EQ(F(d, j), 0.0f);
    EXPECT_EQ(F(j, d), 0.0f);
  }
}

// Per-thread buffers and the dynamic schedule must not change a single bit.
TEST(FormFactorMatrix, SameResultOnOneAndTwoThreads) {
  const Mesh m = closed_unit_cube(3, {0.5, 0.5, 0.5}, {0, 0, 0});
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const FormFactors one = compute_form_factors(m, {64, HemicubeWeights::rrv2007, 0});
  omp_set_num_threads(2);
  const FormFactors two = compute_form_factors(m, {64, HemicubeWeights::rrv2007, 0});
  omp_set_num_threads(threads);
  EXPECT_EQ(one.values, two.values);
}

TEST(FormFactorMatrix, ProgressReportsEndWithTheWhole) {
  const Mesh m = two_facing_squares(2);
  std::vector<size_t> done;
  compute_form_factors(m, {16, HemicubeWeights::exact, 0},
                       [&](size_t d, size_t total, double seconds) {
                         EXPECT_EQ(total, m.size());
                         EXPECT_GE(seconds, 0.0);
                         done.push_back(d);
                       },
                       0.0);
  ASSERT_FALSE(done.empty());
  EXPECT_EQ(done.back(), m.size());
  for (size_t d : done) EXPECT_LE(d, m.size());
}

TEST(HemicubeParams, InvalidValuesAreUsageErrors) {
  const Mesh m = two_facing_squares(1);
  for (int R : {0, 1, 31, -2, 32768})
    EXPECT_THROW(compute_form_factors(m, {R, HemicubeWeights::exact, 0}), hpcgi::UsageError) << R;
  for (double t : {-1e-3, std::nan(""), HUGE_VAL})
    EXPECT_THROW(compute_form_factors(m, {32, HemicubeWeights::exact, t}), hpcgi::UsageError) << t;
  EXPECT_EQ(parse_hemicube_weights("exact"), HemicubeWeights::exact);
  EXPECT_EQ(parse_hemicube_weights(to_string(HemicubeWeights::rrv2007)), HemicubeWeights::rrv2007);
  EXPECT_THROW(parse_hemicube_weights("cosine"), hpcgi::UsageError);
}
