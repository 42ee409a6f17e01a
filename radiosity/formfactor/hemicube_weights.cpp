#include "radiosity/formfactor/hemicube_weights.hpp"

#include <cmath>

#include "radiosity/formfactor/hemicube.hpp"

namespace radiosity {
namespace hemicube {
namespace {

// The delta form factor of pixel (a, r) of face f (Cohen & Greenberg): cos θ_i cos θ_j / (π d²) times its area.
double exact_weight(int R, int f, int a, int r) {
  const double dA = 4.0 / (double(R) * R), x = (a + 0.5) * 2.0 / R - 1.0;
  if (f == kTop) {
    const double y = (r + 0.5) * 2.0 / R - 1.0, q = x * x + y * y + 1.0;
    return dA / (M_PI * q * q);
  }
  const double z = (r + 0.5) * 2.0 / R, q = x * x + z * z + 1.0;
  return z * dA / (M_PI * q * q);
}

// RRV's cos·cos weight of pixel (a, r) of face f, at the pixel's place in the unfolded cross (WeightTable).
double rrv2007_weight(int R, int f, int a, int r) {
  auto c = [R](int k) { return std::cos(M_PI * k / (2.0 * R)); };
  const int h = f == kTop ? r - R / 2 : (f == kPlusU || f == kPlusV) ? R - 1 - r : r - R;
  return c(a - R / 2) * c(h) * 2.0 / (3.0 * double(R) * R);
}

}  // namespace

WeightTable make_weights(const HemicubeParams& p) {
  const int R = p.resolution;
  const bool exact = p.weights == HemicubeWeights::exact;
  WeightTable t;
  for (int f = 0; f < kFaceCount; ++f) {
    const int height = f == kTop ? R : R / 2;
    t.prefix[f].assign(size_t(R + 1) * height, 0.0);
    for (int r = 0; r < height; ++r)
      for (int a = 0; a < R; ++a) {
        const double w = exact ? exact_weight(R, f, a, r) : rrv2007_weight(R, f, a, r);
        double* pre = &t.prefix[f][size_t(r) * (R + 1)];
        pre[a + 1] = pre[a] + w;
      }
  }
  return t;
}

}  // namespace hemicube

double hemicube_weight_total(const HemicubeParams& params) {
  validate(params);
  const hemicube::WeightTable t = hemicube::make_weights(params);
  const size_t stride = size_t(params.resolution) + 1;
  double sum = 0;
  for (const auto& face : t.prefix)
    for (size_t end = stride - 1; end < face.size(); end += stride) sum += face[end];
  return sum;
}

}  // namespace radiosity
