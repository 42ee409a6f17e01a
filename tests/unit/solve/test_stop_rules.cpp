// Stopping rules and the residual history (issue 21): every rule on a closed box of uniform ρ, where Jacobi's
// residual after k steps is ρ^k times the first (closed forms below, computed here, not by the solver), and the
// history of any run replays the run's own stopping decision.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "common/errors.hpp"
#include "radiosity/solve/solve.hpp"
#include "reference.hpp"

using namespace radiosity;
using namespace solve_test;

namespace {

constexpr size_t kN = 33;  // F_ij = 1/32, exact in float: every row sums to 1

std::vector<std::string> every_rule() {
  std::vector<std::string> rules;
  for (const std::string& base : stop_rule_bases())
    for (const char* mod : {"", "+stacked", "+squared", "+stacked+squared"}) rules.push_back(base + mod);
  return rules;
}

// The closed box from b_0 = 0: with every row of F summing to 1 and ρ uniform per channel, b_k = Σ_{i<k} ρ^i e,
// r_k = e - A b_k = ρ^k e (ρ^k times the first, r_0 = e) and b_k - b_{k-1} = ρ^(k-1) e. Every norm is that of the
// uniform vector e_c scaled (2-norm E_c √n, ∞-norm E_c), so each rule's value for b_k is a closed form in ρ, k and
// E; a denominator of 0 (b_0) counts as 1, as the rules say.
double closed_form(const std::string& name, const Rgb& rho, const Rgb& E, long k) {
  const StopRule rule = parse_stop_rule(name);
  Rgb num, den;  // per channel, before stacking: the rule's numerator and denominator (as norms, not squares)
  for (int c = 0; c < 3; ++c) {
    const double unit = rule.base == StopRule::Base::step_inf ? E[c] : E[c] * std::sqrt(double(kN));
    double partial = 0;  // Σ_{i<k} ρ^i: b_k = partial · e
    for (long i = 0; i < k; ++i) partial += std::pow(rho[c], double(i));
    switch (rule.base) {
      case StopRule::Base::residual_e:
      case StopRule::Base::residual_r0: num[c] = std::pow(rho[c], double(k)) * unit, den[c] = unit; break;
      case StopRule::Base::residual_b: num[c] = std::pow(rho[c], double(k)) * unit, den[c] = partial * unit; break;
      case StopRule::Base::step_2:
      case StopRule::Base::step_inf: num[c] = std::pow(rho[c], double(k - 1)) * unit, den[c] = partial * unit; break;
    }
  }
  auto one_if_zero = [](double d) { return d == 0 ? 1.0 : d; };
  double v = 0;
  if (rule.stacked) {
    double n = 0, d = 0;
    for (int c = 0; c < 3; ++c)
      if (rule.base == StopRule::Base::step_inf)
        n = std::max(n, num[c]), d = std::max(d, den[c]);
      else
        n += num[c] * num[c], d += den[c] * den[c];
    v = rule.base == StopRule::Base::step_inf ? n / one_if_zero(d) : std::sqrt(n / one_if_zero(d));
  } else {
    for (int c = 0; c < 3; ++c) v = std::max(v, num[c] / one_if_zero(den[c]));
  }
  return rule.squared ? v * v : v;
}

// The first k the closed form meets tol (a residual rule judges b_k by its residual, a step rule by its step).
long closed_form_count(const std::string& name, const Rgb& rho, const Rgb& E, double tol) {
  const long first = parse_stop_rule(name).on_step() ? 1 : 0;
  for (long k = first;; ++k)
    if (closed_form(name, rho, E, k) <= tol) return k;
}

SolveConfig config(const std::string& method, const std::string& rule, const std::string& precision) {
  SolveConfig c;
  c.backend = "openmp";
  c.method = parse_method(method);
  c.stop = parse_stop_rule(rule);
  c.precision = parse_precision(precision);
  c.tol = 1e-6;
  c.threads = 2;
  c.history = true;
  c.max_iter = 500;
  return c;
}

// The first iterate of the history whose rule value (replayed from the recorded norms) meets tol.
long replayed_count(const SolveResult& r, const std::string& rule, double tol) {
  const StopRule s = parse_stop_rule(rule);
  for (const IterateNorms& k : r.history)
    if (s.value(k, r.e2, r.r0_2) <= tol) return k.iteration;
  return -1;
}

}  // namespace

TEST(StopRules, ParseNamesAndRefuseTheRest) {
  EXPECT_EQ(parse_stop_rule("residual-e").base, StopRule::Base::residual_e);
  const StopRule r = parse_stop_rule("step-inf+squared+stacked");
  EXPECT_EQ(r.base, StopRule::Base::step_inf);
  EXPECT_TRUE(r.stacked && r.squared && r.on_step());
  for (const char* bad : {"", "residual", "step-3", "residual-e+", "residual-e+stacked+stacked", "step-2+cubed"})
    EXPECT_THROW(parse_stop_rule(bad), hpcgi::UsageError) << bad;
  // A rule reads back as the name it prints (the record's "stop"), the modifiers in one order.
  for (const std::string& base : stop_rule_bases())
    for (const char* mods : {"", "+stacked", "+squared", "+stacked+squared"})
      EXPECT_EQ(to_string(parse_stop_rule(base + mods)), base + mods);
  EXPECT_EQ(to_string(parse_stop_rule("step-inf+squared+stacked")), "step-inf+stacked+squared");
}

// Closed box, uniform ρ per channel, from zero: the history's residual after k steps is ρ^k times the first, and
// every rule stops at the step its closed form says.
TEST(StopRules, ClosedBoxJacobiMatchesEveryRulesClosedForm) {
  const Rgb rho{0.5, 0.7, 0.85}, E{1.0, 2.0, 0.5};
  const Problem p = closed_problem(kN, std::vector<Rgb>(kN, rho), std::vector<Rgb>(kN, E));
  for (const std::string& rule : every_rule()) {
    SCOPED_TRACE(rule);
    SolveConfig c = config("jacobi", rule, "double");
    c.start = Start::zero;
    const SolveResult r = solve(p.sys, c);
    ASSERT_EQ(r.status, SolveStatus::converged) << r.detail;
    EXPECT_EQ(r.iterations, closed_form_count(rule, rho, E, c.tol));
    ASSERT_GE(r.history.size(), size_t(r.iterations) + 1);
    const bool on_step = parse_stop_rule(rule).on_step();
    for (size_t k = on_step ? 1 : 0; k + 1 < r.history.size(); ++k) {
      const IterateNorms& h = r.history[k];
      ASSERT_EQ(h.iteration, long(k));
      for (int ch = 0; ch < 3; ++ch) {
        const double rk = std::pow(rho[ch], double(k));
        EXPECT_NEAR(std::sqrt(h.res2[ch]), rk * std::sqrt(r.history[0].res2[ch]), 1e-12 * E[ch]) << k;
      }
      // The residual in double is a difference of iterates up to E / (1 - ρ) ≈ 7 E: its rounding, relative to
      // ‖e‖, is a few 1e-15 however small the residual.
      EXPECT_NEAR(parse_stop_rule(rule).value(h, r.e2, r.r0_2), closed_form(rule, rho, E, long(k)),
                  1e-10 * closed_form(rule, rho, E, long(k)) + 1e-13)
          << k;
    }
  }
}

// From RRV's start on a random system, in float and double, every method and every rule: the first iterate of the
// history that meets the rule is the run's own count, and the run stopped on it.
TEST(StopRules, HistoryReplaysTheSolversOwnStoppingDecision) {
  const Problem p = random_problem(90, 17, 0.3, 0.9);
  for (const char* method : {"jacobi", "gauss-seidel", "sor", "bicgstab"})
    for (const char* precision : {"float", "double"})
      for (const std::string& rule : every_rule()) {
        SCOPED_TRACE(std::string(method) + " " + precision + " " + rule);
        SolveConfig c = config(method, rule, precision);
        if (std::string(method) == "sor") c.omega = 1.2;
        const SolveResult r = solve(p.sys, c);
        ASSERT_EQ(r.status, SolveStatus::converged) << r.detail;
        EXPECT_EQ(replayed_count(r, rule, c.tol), r.iterations);
        EXPECT_GE(r.iterations, 1);
      }
}

TEST(StopRules, StartVectors) {
  const Problem p = random_problem(40, 23);
  for (const char* start : {"rrv", "zero", "emission"}) {
    SCOPED_TRACE(start);
    SolveConfig c = config("jacobi", "residual-e", "double");
    c.start = parse_start(start);
    c.steps = 1;  // b_1 = e + ρ F b_0
    const SolveResult r = solve(p.sys, c);
    const std::vector<Rgb> b0 = start_vector(p.sys, c.start);
    for (size_t i = 0; i < p.sys.n; ++i)
      for (int ch = 0; ch < 3; ++ch) {
        double s = 0;
        for (size_t j = 0; j < p.sys.n; ++j) s += double(p.F[i * p.sys.n + j]) * b0[j][ch];
        EXPECT_NEAR(r.B[i][ch], p.sys.emission[i][ch] + p.sys.reflectivity[i][ch] * s, 1e-12);
      }
    // The history's first entry is b_0: its ∞-norm is b_0's.
    double inf = 0;
    for (const Rgb& b : b0) inf = std::max(inf, b[0]);
    EXPECT_DOUBLE_EQ(r.history.at(0).b_inf[0], inf);
  }
  EXPECT_EQ(start_vector(p.sys, Start::zero)[3], (Rgb{0, 0, 0}));
  EXPECT_EQ(start_vector(p.sys, Start::emission), p.sys.emission);
}
