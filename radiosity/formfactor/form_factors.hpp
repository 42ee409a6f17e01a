// The form-factor matrix and the hemicube parameters that made it: what the hemicube produces, the file stores and
// the solvers read.
#pragma once
#include <cstddef>
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

// F_ij, dense and row-major: values[i*n + j] is the fraction of the energy leaving patch i that arrives at patch j,
// as the radiosity equation B_i = E_i + ρ_i Σ_j F_ij B_j uses it. Row i is what patch i sees; F_ii = 0.
struct FormFactors {
  size_t n = 0;
  std::vector<float> values;
  HemicubeParams params;
  float operator()(size_t i, size_t j) const { return values[i * n + j]; }
};

// Rows [row_begin, row_end) of F: the block of rows one MPI rank computes, holds and writes (radiosity/dist/).
struct FormFactorRows {
  size_t n = 0;  // patches: the length of a row
  size_t row_begin = 0, row_end = 0;
  std::vector<float> values;  // (row_end - row_begin) × n, row-major: values[(i - row_begin)*n + j] = F_ij
  HemicubeParams params;
  size_t rows() const { return row_end - row_begin; }
};

// The whole matrix as the block of all its rows, and back; the values are moved, not copied. from_rows takes a
// block of every row only (row_begin 0, row_end n): anything else is a logic error.
FormFactorRows to_rows(FormFactors&& ff);
FormFactors from_rows(FormFactorRows&& rows);

}  // namespace radiosity
