// The hemicube's five views and the weight of each of their pixels (hemicube.cpp's renderer gathers by them).
// Internal to radiosity/formfactor/.
#pragma once
#include <array>
#include <vector>

#include "radiosity/formfactor/form_factors.hpp"

namespace radiosity::hemicube {

// The five views. In the patch's frame (u, v, n) a point has local coordinates (lu, lv, ln); a view sees it at view
// coordinates (x, y, d): image point (x/d, y/d), depth d along the view direction. On the side views y is the height
// ln, so the hemicube's half of a side face is 0 <= y/d <= 1.
enum Face { kTop, kPlusU, kMinusU, kPlusV, kMinusV, kFaceCount };

// Pixel weights per face, row-major, width R, height R (top) or R/2 (sides); row 0 is y/d = -1 on the top face and
// the horizon on a side face. The rrv2007 table follows RRV's unfolded cross (FormFactorEngine::renderFullScene and
// getFF): its pixel (X, Y) of the 2R × 2R cross has weight cos(π(X-R)/2R)·cos(π(Y-R)/2R), X and Y counted from the
// cross's corner (so the cosines are taken at pixel corners, as RRV does). Mapped to our faces: the along-axis
// pixel a sits at a - R/2 on every face; the height row r sits at R-1-r on the +u, +v faces and r-R on the -u, -v
// faces (RRV renders those views upside down or mirrored), and at r - R/2 on the top.
// Stored as prefix sums along each pixel row (R + 1 entries per row, the first 0), so that a run of pixels showing
// the same patch costs one subtraction when the face is gathered.
struct WeightTable {
  std::array<std::vector<double>, kFaceCount> prefix;
};

WeightTable make_weights(const HemicubeParams& p);

}  // namespace radiosity::hemicube
