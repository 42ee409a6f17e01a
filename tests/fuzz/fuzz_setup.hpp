// The mesh the form-factor fuzz target and its corpus replay read files for: two facing unit squares of two
// triangles each (4 patches, 64 bytes of values), small so that a valid file is small and every mutation of it
// is fast to read. tests/fuzz/make_ff_seeds writes the seed files for exactly this mesh.
#pragma once
#include "radiosity/scene/analytic.hpp"

namespace fuzz {

inline radiosity::Mesh ff_mesh() { return radiosity::two_facing_squares(1); }

}  // namespace fuzz
