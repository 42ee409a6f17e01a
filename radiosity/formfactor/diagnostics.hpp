// Checks of a form-factor matrix by the properties exact form factors have: rows of a closed scene sum to 1
// (energy leaving a patch lands somewhere), and reciprocity A_i F_ij = A_j F_ji.
#pragma once
#include <cstddef>

#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"

namespace radiosity {

struct FormFactorDiagnostics {
  double min_row_sum = 0, max_row_sum = 0;  // over all rows of Σ_j F_ij
  size_t min_row = 0, max_row = 0;          // the rows where they occur
  // Reciprocity over the pairs i < j whose form factors are both non-negligible: F_ij >= min_form_factor and
  // F_ji >= min_form_factor. Per pair the error is |A_i F_ij - A_j F_ji| / max(A_i F_ij, A_j F_ji).
  size_t pairs_compared = 0;
  double max_reciprocity_error = 0;  // the worst pair: 0 when no pair qualifies
  size_t worst_i = 0, worst_j = 0;
  // Σ |A_i F_ij - A_j F_ji| / Σ max(A_i F_ij, A_j F_ji) over the same pairs: the typical error, weighted by the
  // energy the pairs exchange.
  double mean_reciprocity_error = 0;
};

// The hemicube samples each row from one point, patch i's centroid, so reciprocity is only approximate: for
// neighbouring patches (distance comparable to their size) the point-to-area form factors from the two centroids
// differ by tens of percent, and a form factor covering few pixels carries a pixel-counting error. The default
// threshold 1e-3 is worth about 50 pixels at the centre of the top face at R = 256 (a pixel there is
// 4/(πR²) ≈ 1.9e-5). Throws UsageError if the matrix does not match the mesh.
FormFactorDiagnostics diagnose_form_factors(const Mesh& mesh, const FormFactors& ff, double min_form_factor = 1e-3);

}  // namespace radiosity
