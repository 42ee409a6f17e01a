// Stopping rules and the residual history (issue 21): the measures a 2014 code would plausibly have stopped on,
// computed from the norms every iteration has at O(n) cost beside its O(n²) product, so that one run's history
// says when any rule would have stopped it (analysis/table42_audit.py evaluates them the same way).
//
// A rule is BASE[+stacked][+squared]:
//   residual-e   ‖e − A b_k‖₂ / ‖e‖₂ (ours, the default)      residual-r0  ‖e − A b_k‖₂ / ‖e − A b_0‖₂
//   residual-b   ‖e − A b_k‖₂ / ‖b_k‖₂                        step-2       ‖b_k − b_{k−1}‖₂ / ‖b_k‖₂
//   step-inf     ‖b_k − b_{k−1}‖∞ / ‖b_k‖∞
// per channel, the largest of r, g, b (default), or +stacked: over the three channels stacked into one vector; and
// +squared: the value squared (the code compared ‖r‖² with tol). A denominator that is 0 counts as 1 (a channel
// without light has the solution 0 and is measured absolutely, as residual_scale does).
#pragma once
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

// What one iterate b_k is measured by, squares of 2-norms per channel. NaN where not known: the residual of the
// last Jacobi or Gauss-Seidel iterate (it comes with the next sweep), the step of b_0.
struct IterateNorms {
  long iteration = 0;  // k
  Rgb res2{}, step2{}, step_inf{}, b2{}, b_inf{};
};

struct StopRule {
  enum class Base { residual_e, residual_r0, residual_b, step_2, step_inf };
  Base base = Base::residual_e;
  bool stacked = false, squared = false;
  bool on_step() const { return base == Base::step_2 || base == Base::step_inf; }
  bool needs_b() const { return base == Base::residual_b || on_step(); }
  bool operator==(const StopRule& o) const { return base == o.base && stacked == o.stacked && squared == o.squared; }
  bool operator!=(const StopRule& o) const { return !(*this == o); }
  // The rule's value for b_k per channel (stacked: the same stacked value in every channel), given ‖e‖² and
  // ‖r_0‖² per channel.
  Rgb values(const IterateNorms& k, const Rgb& e2, const Rgb& r0_2) const;
  // The largest of values(): the rule is met when it is <= tol.
  double value(const IterateNorms& k, const Rgb& e2, const Rgb& r0_2) const;
};

// The rules' names, for --help and the errors.
const std::vector<std::string>& stop_rule_bases();
// Throws hpcgi::UsageError for an unknown base or modifier.
StopRule parse_stop_rule(const std::string& name);

}  // namespace radiosity
