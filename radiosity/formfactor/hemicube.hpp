// Form factors by the hemicube (Cohen & Greenberg 1985), rendered in software on the CPU.
//
// For patch i: the eye sits at its centroid looking along its normal; five views (the full top face, R × R pixels,
// and four half side faces, R × R/2) are rendered into an item buffer with a z-buffer, and each pixel adds its
// weight to the patch it shows: F_ij = Σ weights of the pixels showing j. Rows are independent, one OpenMP task
// each.
//
// Fidelity to RRV 2007 (see shared/scenes/FORMAT.md): the same eye frame (side = n × (1,2,3), up = side × n) and
// pixel layout of the unfolded cross in both weightings; with rrv2007 weights also RRV's near plane 0.001 and far
// plane 50 (with exact weights the near plane is 1e-6·√A_i and there is no far plane, so nothing visible is lost).
// No back-face culling in either: a patch seen from behind occludes and receives, as in RRV. Not reproduced: RRV's
// 16-bit depth buffer (ours is float 1/d) and OpenGL's exact rasterisation (ours: 8 sub-pixel bits, pixel centres,
// top-left rule). Patches wholly on or behind patch i's plane are skipped: they could only fall on the lower
// halves of the side views, which no hemicube reads, so skipping them changes no value in either weighting.
#pragma once
#include <functional>

#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"

namespace radiosity {

// Called now and then (at most once per interval, from one thread at a time) with the patches done so far, the
// total and the seconds since the computation started.
using HemicubeProgress = std::function<void(size_t done, size_t total, double seconds)>;

// A progress callback printing "form factors: 1200/9680 patches, 12.3 s, 97.6 patches/s" lines on stderr.
HemicubeProgress stderr_progress();

// All n² form factors of the mesh. Throws UsageError for invalid parameters (validate()).
FormFactors compute_form_factors(const Mesh& mesh, const HemicubeParams& params,
                                 const HemicubeProgress& progress = {}, double progress_interval_s = 5.0);

// The sum of the pixel weights over the whole hemicube: what a patch that sees only other patches gets as its row
// sum. 1 up to discretisation with exact weights; about 0.988 with rrv2007 weights.
double hemicube_weight_total(const HemicubeParams& params);

}  // namespace radiosity
