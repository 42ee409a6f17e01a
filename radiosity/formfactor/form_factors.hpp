// The form-factor matrix and the hemicube parameters that made it: what the hemicube produces, the file stores and
// the solvers read.
#pragma once
#include <cstddef>
#include <cstdint>
#include <utility>
#include <string>
#include <vector>

namespace radiosity {

// How a hemicube pixel is weighted.
//   exact:   Cohen & Greenberg's delta form factors, ΔF = ΔA / (π (x² + y² + 1)²) on the top face and
//            ΔF = z ΔA / (π (y² + z² + 1)²) on a side face, at the pixel centre: they sum to 1 over the hemicube
//            up to an O(1/R²) midpoint error.
//   rrv2007: RRV's cos(πx/2R)·cos(πy/2R), x, y in pixels from the centre of the unfolded 2R × 2R cross, and
//            F_ij = 2·Σw / (3R²); at RRV's R = 256 that is its cos(πx/512)·cos(πy/512) and 2·Σw / 196608. An
//            approximation that sums to about 0.988 over the hemicube, kept to reproduce RRV's numbers.
enum class HemicubeWeights { exact, rrv2007 };

std::string to_string(HemicubeWeights w);
// "exact" or "rrv2007"; anything else is a UsageError.
HemicubeWeights parse_hemicube_weights(const std::string& name);

struct HemicubeParams {
  int resolution = 256;  // R: pixels along a full face; the four side faces are R × R/2. Even, 2..16384.
  HemicubeWeights weights = HemicubeWeights::exact;
  double threshold = 0;  // form factors <= threshold are stored as 0 (RRV's threshold, default 0)
};

// Throws UsageError for a resolution that is odd or out of range or a threshold that is negative or not finite.
void validate(const HemicubeParams& p);

// F_ij, dense and row-major, as the hemicube computes it and the file stores it: rows [row_begin, row_end) of the n
// rows (every row, or the block one MPI rank computes, holds and writes: radiosity/dist/), row i at
// values[(i - row_begin)*n + j], the fraction of the energy leaving patch i that arrives at patch j, as the radiosity
// equation B_i = E_i + ρ_i Σ_j F_ij B_j uses it. Row i is what patch i sees; F_ii = 0. row_end = SIZE_MAX: every row.
// A solve holds it as a FormFactorMatrix (solve/storage/ff_matrix.hpp), the values moved, not copied.
struct FormFactors {
  size_t n = 0;
  std::vector<float> values;
  HemicubeParams params;
  size_t row_begin = 0, row_end = SIZE_MAX;
  size_t first_row() const { return row_begin < n ? row_begin : n; }
  size_t last_row() const { return row_end < n ? row_end : n; }
  size_t rows() const { return last_row() - first_row(); }
  bool all_rows() const { return first_row() == 0 && last_row() == n; }
  float operator()(size_t i, size_t j) const { return values[(i - row_begin) * n + j]; }
};

}  // namespace radiosity
