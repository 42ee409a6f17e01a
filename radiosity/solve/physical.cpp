#include "radiosity/solve/physical.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

namespace radiosity {

PhysicalCheck check_physical(const System& sys, const std::vector<Rgb>& B, const Rgb& rel_residual, double tol,
                             Precision working) {
  PhysicalCheck c;
  const double eps = working == Precision::double_ ? std::numeric_limits<double>::epsilon()
                                                   : double(std::numeric_limits<float>::epsilon());
  const Rgb scale = residual_scale(sys);
  double allowed[3];
  for (int ch = 0; ch < 3; ++ch)
    allowed[ch] = std::fmax(tol, std::isfinite(rel_residual[ch]) ? rel_residual[ch] : 0.0) * scale[ch];
  size_t worst_i = 0;
  int worst_c = 0;
  double worst = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < B.size() && i < sys.n; ++i) {
    for (int ch = 0; ch < 3; ++ch) {
      const double b = B[i][ch], e = sys.emission[i][ch];
      if (!std::isfinite(b)) {
        char why[160];
        std::snprintf(why, sizeof why, "the radiosity of patch %zu, channel %c, is %s", i, "rgb"[ch],
                      std::isnan(b) ? "NaN" : b > 0 ? "inf" : "-inf");
        c.status = SolveStatus::nonfinite;
        c.detail = why;
        c.min_margin = -std::numeric_limits<double>::infinity();
        return c;
      }
      const double margin = (b - e) + allowed[ch] + 8 * eps * (std::fabs(b) + std::fabs(e));
      if (margin < worst) worst = margin, worst_i = i, worst_c = ch;
    }
  }
  c.min_margin = B.empty() ? 0 : worst;
  if (worst < 0) {
    const double b = B[worst_i][worst_c], e = sys.emission[worst_i][worst_c];
    char why[512];
    std::snprintf(why, sizeof why,
                  "B - E = %.6g at patch %zu, channel %c (B = %.6g, E = %.6g), below the %.3g the answer's residual "
                  "and rounding allow: the light is amplified, not absorbed (the spectral radius of rho F is 1 or "
                  "more), so no physical radiosity exists",
                  b - e, worst_i, "rgb"[worst_c], b, e, allowed[worst_c] + 8 * eps * (std::fabs(b) + std::fabs(e)));
    c.status = SolveStatus::unphysical;
    c.detail = why;
  }
  return c;
}

bool require_physical(const System& sys, SolveResult& res, double tol, Precision working) {
  if (failed(res.status)) return false;
  const PhysicalCheck c = check_physical(sys, res.B, res.rel_residual, tol, working);
  if (c.status == SolveStatus::converged) return true;
  res.status = c.status;
  res.detail = c.detail;
  return false;
}

}  // namespace radiosity
