#include "radiosity/formfactor/diagnostics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/errors.hpp"

namespace radiosity {

FormFactorDiagnostics diagnose_form_factors(const Mesh& mesh, const FormFactors& ff, double min_form_factor) {
  const size_t n = mesh.size();
  if (ff.n != n || ff.values.size() != n * n)
    throw hpcgi::UsageError("form factors are for " + std::to_string(ff.n) + " patches, the mesh has " +
                            std::to_string(n));
  FormFactorDiagnostics d;
  if (n == 0) return d;

  std::vector<double> area(n), row_sum(n);
  for (size_t i = 0; i < n; ++i) area[i] = mesh.patches[i].area();
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < int64_t(n); ++i) {
    double s = 0;
    for (size_t j = 0; j < n; ++j) s += ff.values[size_t(i) * n + j];
    row_sum[i] = s;
  }
  const auto [lo, hi] = std::minmax_element(row_sum.begin(), row_sum.end());
  d.min_row_sum = *lo;
  d.max_row_sum = *hi;
  d.min_row = size_t(lo - row_sum.begin());
  d.max_row = size_t(hi - row_sum.begin());

  // Pairs (i, j) and (j, i) in square tiles, so that the column reads F_ji stay in cache.
  constexpr size_t kTile = 64;
  const size_t tiles = (n + kTile - 1) / kTile;
  double sum_diff = 0, sum_max = 0;
#pragma omp parallel
  {
    size_t pairs = 0, wi = 0, wj = 0;
    double worst = -1, diff = 0, big = 0;
#pragma omp for schedule(dynamic, 1) nowait
    for (int64_t ti = 0; ti < int64_t(tiles); ++ti)
      for (size_t tj = size_t(ti); tj < tiles; ++tj)
        for (size_t i = size_t(ti) * kTile; i < std::min(n, (size_t(ti) + 1) * kTile); ++i)
          for (size_t j = std::max(i + 1, tj * kTile); j < std::min(n, (tj + 1) * kTile); ++j) {
            const float fij = ff.values[i * n + j], fji = ff.values[j * n + i];
            if (fij < min_form_factor || fji < min_form_factor) continue;
            const double a = area[i] * fij, b = area[j] * fji, m = std::max(a, b), e = std::abs(a - b) / m;
            ++pairs;
            diff += std::abs(a - b);
            big += m;
            if (e > worst) {
              worst = e;
              wi = i;
              wj = j;
            }
          }
#pragma omp critical(diagnose_form_factors)
    {
      d.pairs_compared += pairs;
      sum_diff += diff;
      sum_max += big;
      if (worst > d.max_reciprocity_error) {
        d.max_reciprocity_error = worst;
        d.worst_i = wi;
        d.worst_j = wj;
      }
    }
  }
  d.mean_reciprocity_error = sum_max > 0 ? sum_diff / sum_max : 0;
  return d;
}

}  // namespace radiosity
