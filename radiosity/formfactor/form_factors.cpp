#include "radiosity/formfactor/form_factors.hpp"

#include <cmath>

#include "common/errors.hpp"

namespace radiosity {

std::string to_string(HemicubeWeights w) { return w == HemicubeWeights::exact ? "exact" : "rrv2007"; }

HemicubeWeights parse_hemicube_weights(const std::string& name) {
  if (name == "exact") return HemicubeWeights::exact;
  if (name == "rrv2007") return HemicubeWeights::rrv2007;
  throw hpcgi::UsageError("unknown hemicube weights '" + name + "' (expected exact or rrv2007)");
}

void validate(const HemicubeParams& p) {
  // Even: the side faces are R/2 pixels high. The upper bound keeps fixed-point edge functions in 64 bits with a
  // wide margin and a face buffer (R² pixels per thread) within reason.
  if (p.resolution < 2 || p.resolution > 16384 || p.resolution % 2 != 0)
    throw hpcgi::UsageError("hemicube resolution must be an even number in 2..16384, got " +
                            std::to_string(p.resolution));
  if (!std::isfinite(p.threshold) || p.threshold < 0)
    throw hpcgi::UsageError("form-factor threshold must be finite and >= 0, got " + std::to_string(p.threshold));
}

}  // namespace radiosity
