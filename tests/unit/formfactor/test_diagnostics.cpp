// The diagnostics on matrices whose answers are worked out by hand, and against a brute-force loop on a matrix
// whose size is not a multiple of the tile.
#include <gtest/gtest.h>

#include <random>

#include "common/errors.hpp"
#include "radiosity/formfactor/diagnostics.hpp"

using namespace radiosity;

namespace {

// Right triangles with legs a, b in the plane z = 0: area a·b/2.
Mesh triangles_with_legs(const std::vector<std::pair<double, double>>& legs) {
  Mesh m;
  m.entities = {"t"};
  for (auto [a, b] : legs) {
    Patch p;
    p.v = {Vec3{0, 0, 0}, Vec3{a, 0, 0}, Vec3{0, b, 0}};
    m.patches.push_back(p);
  }
  return m;
}

FormFactors matrix(size_t n, const std::vector<float>& values) {
  FormFactors f;
  f.n = n;
  f.values = values;
  return f;
}

}  // namespace

TEST(Diagnostics, HandWorkedExample) {
  const Mesh m = triangles_with_legs({{1, 2}, {2, 2}, {2, 4}});  // areas 1, 2, 4
  // A0 F01 = 0.2 = A1 F10: reciprocal. A0 F02 = 0.4, A2 F20 = 0.2: error 0.5. F12 = 0.0005 is negligible.
  const FormFactors f = matrix(3, {0.0f, 0.2f, 0.4f,  //
                                   0.1f, 0.0f, 0.0005f,  //
                                   0.05f, 0.3f, 0.0f});
  const FormFactorDiagnostics d = diagnose_form_factors(m, f);
  EXPECT_NEAR(d.min_row_sum, 0.1005, 1e-7);
  EXPECT_EQ(d.min_row, 1u);
  EXPECT_NEAR(d.max_row_sum, 0.6, 1e-7);
  EXPECT_EQ(d.max_row, 0u);
  EXPECT_EQ(d.pairs_compared, 2u);
  EXPECT_NEAR(d.max_reciprocity_error, 0.5, 1e-6);
  EXPECT_EQ(d.worst_i, 0u);
  EXPECT_EQ(d.worst_j, 2u);
  EXPECT_NEAR(d.mean_reciprocity_error, 0.2 / 0.6, 1e-6);  // Σ|difference| / Σ max = (0 + 0.2) / (0.2 + 0.4)

  // A lower threshold admits the pair (1, 2): A1 F12 = 0.001 against A2 F21 = 1.2.
  const FormFactorDiagnostics all = diagnose_form_factors(m, f, 1e-4);
  EXPECT_EQ(all.pairs_compared, 3u);
  EXPECT_NEAR(all.max_reciprocity_error, 1 - 0.001 / 1.2, 1e-6);
  EXPECT_EQ(all.worst_i, 1u);
  EXPECT_EQ(all.worst_j, 2u);
}

TEST(Diagnostics, TiledLoopMatchesBruteForce) {
  const size_t n = 150;  // two full tiles of 64 and a partial one
  std::vector<std::pair<double, double>> legs;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> leg(0.5, 2.0), value(0.0, 0.01);
  for (size_t i = 0; i < n; ++i) legs.push_back({leg(rng), leg(rng)});
  const Mesh m = triangles_with_legs(legs);
  std::vector<float> v(n * n);
  for (float& x : v) x = static_cast<float>(value(rng));
  const FormFactors f = matrix(n, v);

  size_t pairs = 0;
  double worst = 0, diff = 0, big = 0;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      const float fij = v[i * n + j], fji = v[j * n + i];
      if (fij < 1e-3 || fji < 1e-3) continue;
      const double a = m.patches[i].area() * fij, b = m.patches[j].area() * fji;
      ++pairs;
      worst = std::max(worst, std::abs(a - b) / std::max(a, b));
      diff += std::abs(a - b);
      big += std::max(a, b);
    }
  const FormFactorDiagnostics d = diagnose_form_factors(m, f);
  EXPECT_EQ(d.pairs_compared, pairs);
  EXPECT_DOUBLE_EQ(d.max_reciprocity_error, worst);
  EXPECT_NEAR(d.mean_reciprocity_error, diff / big, 1e-12);
  const size_t i = d.worst_i, j = d.worst_j;
  const double a = m.patches[i].area() * v[i * n + j], b = m.patches[j].area() * v[j * n + i];
  EXPECT_DOUBLE_EQ(std::abs(a - b) / std::max(a, b), worst);
}

TEST(Diagnostics, MatrixForAnotherMeshIsRefused) {
  const Mesh m = triangles_with_legs({{1, 1}, {1, 1}});
  EXPECT_THROW(diagnose_form_factors(m, matrix(3, std::vector<float>(9, 0.0f))), hpcgi::UsageError);
}
