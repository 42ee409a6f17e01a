// poisson/config/config.hpp and verify.hpp: the names parsed once, the one place a configuration is refused, the table
// of backends, and the float64 check's bound.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "common/errors.hpp"
#include "poisson/config/config.hpp"
#include "poisson/config/problem.hpp"
#include "poisson/verify.hpp"

namespace {

using poisson::Backend, poisson::Method, poisson::Precond, poisson::Variant;

template <class E, class P>
void round_trips(P parse) {
  for (const std::string& n : poisson::choice_names<E>()) EXPECT_EQ(poisson::to_string(parse(n)), n);
  EXPECT_THROW(parse(""), hpcgi::UsageError);
  EXPECT_THROW(parse("Classic"), hpcgi::UsageError);
}

TEST(Config, EveryNameRoundTrips) {
  round_trips<Backend>(poisson::parse_backend);
  round_trips<Variant>(poisson::parse_variant);
  round_trips<Precond>(poisson::parse_precond);
  round_trips<Method>(poisson::parse_method);
  round_trips<poisson::Halo>(poisson::parse_halo);
  round_trips<poisson::Precision>(poisson::parse_precision);
}

poisson::Config on(Backend b) {
  poisson::Config c;
  c.backend = b;
  return c;
}

TEST(Config, CheckConfigRefusesWhatNoBackendRunsAsAsked) {
  poisson::Config c = on(Backend::openmp);
  EXPECT_NO_THROW(poisson::check_config(c));
  c.method = Method::fmg;
  EXPECT_NO_THROW(poisson::check_config(c));
  c.precond = Precond::mg;  // fmg takes no --precond
  EXPECT_THROW(poisson::check_config(c), hpcgi::UsageError);
  c = on(Backend::openmp);
  c.precond = Precond::mg;
  c.variant = Variant::onesweep;  // preconditioned CG is classic
  EXPECT_THROW(poisson::check_config(c), hpcgi::UsageError);
  c = on(Backend::openmp);
  c.check_symmetry = true;  // needs --precond mg
  EXPECT_THROW(poisson::check_config(c), hpcgi::UsageError);
  c.precond = Precond::mg;
  EXPECT_NO_THROW(poisson::check_config(c));
  for (Backend b : {Backend::cublas1, Backend::cublas2}) {  // no multigrid, no onesweep: refused, built or not
    c = on(b);
    c.precond = Precond::mg;
    EXPECT_THROW(poisson::check_config(c), hpcgi::UsageError);
    c = on(b);
    c.variant = Variant::onesweep;
    EXPECT_THROW(poisson::check_config(c), hpcgi::UsageError);
  }
}

TEST(Config, TheTableIsInTheEnumsOrderWithItsVectors) {
  const auto& t = poisson::backends();
  ASSERT_EQ(t.size(), poisson::choice_names<Backend>().size());
  for (size_t k = 0; k < t.size(); ++k) {
    EXPECT_EQ(static_cast<size_t>(t[k].id), k);
    EXPECT_GT(t[k].vectors_classic, 0) << t[k].name();
    EXPECT_EQ(t[k].vectors_onesweep > 0, t[k].onesweep) << t[k].name();
    EXPECT_EQ(t[k].built, t[k].why_not.empty()) << t[k].name();
  }
  EXPECT_EQ(poisson::kDefaultMaxIter.of(10), 1000);
  EXPECT_EQ(poisson::kDefaultMaxIter.of(300), 1200);
}

// ||b||_2 through the separable sum equals the sum over every point.
TEST(Verify, RhsNormEqualsThePointwiseSum) {
  for (long n : {1L, 2L, 7L, 64L, 129L}) {
    const poisson::Grid g{n};
    double s = 0;
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i) s += g.b(i, j) * g.b(i, j);
    EXPECT_NEAR(poisson::rhs_norm2(n), std::sqrt(s), 1e-12 * std::sqrt(s)) << n;
  }
}

TEST(Verify, TheBoundIsItsThreeTermsAndTheHookTightensIt) {
  unsetenv("HPCGI_TEST_POISSON_BOUND");
  const long n = 63;
  const double h = 1.0 / 64, pi = poisson::kPi;
  const poisson::Check c = poisson::check_answer(n, 1e-6, 1e-16, 1e-3);
  EXPECT_NEAR(c.discretisation, std::pow(pi, 4) * h * h / 6, 1e-15);
  EXPECT_NEAR(c.algebraic, 1e-6 * poisson::rhs_norm2(n) / (8 * std::pow(std::sin(pi * h / 2), 2)), 1e-18);
  EXPECT_DOUBLE_EQ(c.bound, c.discretisation + c.algebraic + 1e-16);
  EXPECT_TRUE(c.agreed);
  EXPECT_FALSE(poisson::check_answer(n, 1e-6, 1e-16, c.bound * 1.01).agreed);
  EXPECT_FALSE(poisson::check_answer(n, 1e-6, 1e-16, std::nan("")).agreed);
  setenv("HPCGI_TEST_POISSON_BOUND", "0.5", 1);
  EXPECT_DOUBLE_EQ(poisson::check_answer(n, 1e-6, 1e-16, 1e-3).bound, 0.5 * c.bound);
  setenv("HPCGI_TEST_POISSON_BOUND", "1.5", 1);
  EXPECT_THROW(poisson::check_answer(n, 1e-6, 1e-16, 1e-3), hpcgi::UsageError);
  unsetenv("HPCGI_TEST_POISSON_BOUND");
}

}  // namespace
