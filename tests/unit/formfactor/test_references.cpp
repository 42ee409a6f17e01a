// The references themselves: Howell's closed forms give the catalogue's values, and the point-to-polygon formula,
// integrated over the emitting square, agrees with them; so the two kinds of reference check each other.
#include <gtest/gtest.h>

#include "radiosity/scene/analytic.hpp"
#include "tests/unit/formfactor/references.hpp"

using namespace fftest;

TEST(References, HowellValuesOfTheThreeConfigurations) {
  EXPECT_NEAR(howell_parallel_rectangles(1, 1, 1), 0.199825, 5e-7);
  EXPECT_NEAR(howell_perpendicular_rectangles(1, 1, 1), 0.200044, 5e-7);
  EXPECT_NEAR(howell_coaxial_disks(1, 1, 1), 0.381966, 5e-7);
  EXPECT_NEAR(howell_coaxial_disks(1, 1, 1), (3 - std::sqrt(5.0)) / 2, 1e-15);  // X = 3: (3 - √5)/2
}

// A closed cube: one opposite face and four adjacent ones take everything: F_opp + 4·F_adj = 1.
TEST(References, HowellFactorsOfACubeSumToOne) {
  EXPECT_NEAR(howell_parallel_rectangles(1, 1, 1) + 4 * howell_perpendicular_rectangles(1, 1, 1), 1.0, 1e-6);
}

// Midpoint rule over an m × m grid on square 1 of the point-to-square formula, summed over square 2's triangles.
static double integrate_point_formula(const radiosity::Mesh& target, int m) {
  double sum = 0;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) {
      const Vec3 p{(a + 0.5) / m, (b + 0.5) / m, 0};
      for (const Patch& t : target.patches)
        if (t.entity == 1) sum += point_to_triangle(p, {0, 0, 1}, t);
    }
  return sum / (double(m) * m);
}

TEST(References, PointFormulaIntegratesToHowellFacing) {
  EXPECT_NEAR(integrate_point_formula(radiosity::two_facing_squares(1), 64), howell_parallel_rectangles(1, 1, 1),
              2e-5);
}

TEST(References, PointFormulaIntegratesToHowellPerpendicular) {
  // The integrand has a logarithmic derivative at the shared edge: the midpoint rule converges more slowly there.
  EXPECT_NEAR(integrate_point_formula(radiosity::perpendicular_squares(1), 128),
              howell_perpendicular_rectangles(1, 1, 1), 1e-4);
}

TEST(References, PointFormulaMatchesHowellPointToRectangle) {
  // From (0.2, 0.3, 0) to the unit square at height 1: four corner rectangles meet above the point.
  const radiosity::Mesh m = radiosity::two_facing_squares(1);
  double lambert = 0;
  for (const Patch& t : m.patches)
    if (t.entity == 1) lambert += point_to_triangle({0.2, 0.3, 0}, {0, 0, 1}, t);
  const double howell = howell_point_to_parallel_rectangle_corner(0.2, 0.3, 1) +
                        howell_point_to_parallel_rectangle_corner(0.8, 0.3, 1) +
                        howell_point_to_parallel_rectangle_corner(0.2, 0.7, 1) +
                        howell_point_to_parallel_rectangle_corner(0.8, 0.7, 1);
  EXPECT_NEAR(lambert, howell, 1e-12);
}

TEST(References, PointFormulaOfAFullHemisphereIsOne) {
  // From the centre of the cube's floor, the other five faces fill the whole hemisphere.
  const radiosity::Mesh cube = radiosity::closed_unit_cube(1, {0, 0, 0}, {0, 0, 0});
  double sum = 0;
  for (const Patch& t : cube.patches)
    if (cube.entities[t.entity] != "z0") sum += point_to_triangle({0.5, 0.5, 0}, {0, 0, 1}, t);
  EXPECT_NEAR(sum, 1.0, 1e-12);
}
