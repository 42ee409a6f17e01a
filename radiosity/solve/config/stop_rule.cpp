#include "radiosity/solve/config/stop_rule.hpp"

#include <algorithm>
#include <cmath>

#include "common/errors.hpp"

namespace radiosity {
namespace {

double denominator(double d) { return d == 0 ? 1.0 : d; }

}  // namespace

const std::vector<std::string>& stop_rule_bases() {
  static const std::vector<std::string> names = {"residual-e", "residual-r0", "residual-b", "step-2", "step-inf"};
  return names;
}

StopRule parse_stop_rule(const std::string& name) {
  StopRule r;
  const size_t plus = name.find('+');
  const std::string base = name.substr(0, plus);
  const auto& names = stop_rule_bases();
  const auto it = std::find(names.begin(), names.end(), base);
  std::string known;
  for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
  if (it == names.end())
    throw hpcgi::UsageError("unknown stopping rule '" + name + "' (known: " + known + ", each with +stacked, +squared)");
  r.base = static_cast<StopRule::Base>(it - names.begin());
  for (size_t at = plus; at != std::string::npos;) {
    const size_t next = name.find('+', at + 1);
    const std::string mod = name.substr(at + 1, next == std::string::npos ? std::string::npos : next - at - 1);
    if (mod == "stacked" && !r.stacked)
      r.stacked = true;
    else if (mod == "squared" && !r.squared)
      r.squared = true;
    else
      throw hpcgi::UsageError("stopping rule '" + name + "': unknown or repeated modifier '+" + mod +
                              "' (known: +stacked, +squared)");
    at = next;
  }
  return r;
}

Rgb StopRule::values(const IterateNorms& k, const Rgb& e2, const Rgb& r0_2) const {
  // Numerator and denominator per channel, as 2-norm squares (inf: the ∞-norms themselves, squared).
  Rgb num, den;
  for (int c = 0; c < 3; ++c) {
    switch (base) {
      case Base::residual_e: num[c] = k.res2[c], den[c] = e2[c]; break;
      case Base::residual_r0: num[c] = k.res2[c], den[c] = r0_2[c]; break;
      case Base::residual_b: num[c] = k.res2[c], den[c] = k.b2[c]; break;
      case Base::step_2: num[c] = k.step2[c], den[c] = k.b2[c]; break;
      case Base::step_inf: num[c] = k.step_inf[c] * k.step_inf[c], den[c] = k.b_inf[c] * k.b_inf[c]; break;
    }
  }
  Rgb v;
  if (stacked) {
    double n = 0, d = 0;
    for (int c = 0; c < 3; ++c)
      if (base == Base::step_inf) {  // the largest over the channels; a NaN (not known) stays NaN
        n = std::isnan(num[c]) || num[c] > n ? num[c] : n;
        d = std::isnan(den[c]) || den[c] > d ? den[c] : d;
      } else {
        n += num[c];
        d += den[c];
      }
    const double s = std::sqrt(n / denominator(d));
    v = {s, s, s};
  } else {
    for (int c = 0; c < 3; ++c) v[c] = std::sqrt(num[c] / denominator(den[c]));
  }
  if (squared)
    for (double& x : v) x *= x;
  return v;
}

double StopRule::value(const IterateNorms& k, const Rgb& e2, const Rgb& r0_2) const {
  const Rgb v = values(k, e2, r0_2);
  // NaN (a norm not known, or a non-finite iterate) is never <= tol: the largest keeps it.
  double worst = v[0];
  for (int c = 1; c < 3; ++c)
    if (std::isnan(v[c]) || v[c] > worst) worst = v[c];
  return worst;
}

}  // namespace radiosity
