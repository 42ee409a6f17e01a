// A finer mesh's radiosity carried onto a coarser mesh of the same scene, so that the error of a coarse mesh
// (a larger --divide) can be measured against the finest one: each coarse patch gets the area-weighted mean of
// the fine patches it contains, B_I = Σ_{i ⊂ I} A_i B_i / Σ_{i ⊂ I} A_i, which is the coarse patch's mean
// radiosity, what a piecewise-constant solution on it should approximate.
//
// The subdivision rule (scene/subdivide.hpp) splits a triangle in four at its midpoints until it is small enough,
// and a smaller maximum area only splits further, computing the same midpoints: a fine mesh of the same scene is
// a refinement of every coarser one, each fine patch inside exactly one coarse patch of the same entity.
#pragma once
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

// For every fine patch, the coarse patch of the same entity that contains it (its centroid, within rounding).
// Throws hpcgi::UsageError when `fine` is not a refinement of `coarse` (a fine patch in no coarse patch, or the
// fine areas in a coarse patch not adding up to its area), naming the first patch that fails.
std::vector<size_t> containing_patches(const Mesh& coarse, const Mesh& fine);

// The area-weighted mean of the fine radiosity over each coarse patch.
std::vector<Rgb> area_weighted_onto(const Mesh& coarse, const Mesh& fine, const std::vector<Rgb>& fine_B);

}  // namespace radiosity
