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

// Rows [row_begin, row_end) of F, each exactly as compute_form_factors computes it (a row depends on nothing but
// the mesh and the parameters), so blocks computed apart and put together give the same bits. Throws UsageError for
// invalid parameters or a range outside the mesh.
FormFactors compute_form_factor_rows(const Mesh& mesh, const HemicubeParams& params, size_t row_begin,
                                     size_t row_end, const HemicubeProgress& progress = {},
                                     double progress_interval_s = 5.0);

// An estimate of each row's hemicube cost in nanoseconds on one core, to split the rows among MPI ranks by work
// (radiosity/dist/split.hpp): a row transforms every patch, clips and rasterises those in front of the patch's
// plane, and clears and gathers the hemicube's 3R² pixels; patches in front are counted on an evenly spaced sample of
// at most `sample` patches. Deterministic: every rank computes the same estimate, so all agree on the split
// without talking.
std::vector<uint64_t> hemicube_row_work(const Mesh& mesh, const HemicubeParams& params, size_t sample = 2048);

// Bytes a computation of `rows` rows of an n-patch mesh holds besides the mesh: the rows' float32 values, the
// patches' corners, and per thread a row of doubles, the patches' coordinates in the row's frame, its lists of
// patches per face and the item and depth buffers of R² pixels; and once the weight table of the 3R² pixels.
double hemicube_memory_bytes(size_t n, size_t rows, int resolution, int threads);

// The sum of the pixel weights over the whole hemicube: what a patch that sees only other patches gets as its row
// sum. 1 up to discretisation with exact weights; about 0.988 with rrv2007 weights.
double hemicube_weight_total(const HemicubeParams& params);

}  // namespace radiosity
