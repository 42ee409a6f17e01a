// What the fuzz targets and the corpus replay (tests/unit/fuzz_corpus) share, so that make test replays every
// input exactly as the fuzzer ran it.
#pragma once
#include "radiosity/scene/analytic.hpp"
#include "radiosity/scene/rrv_reader.hpp"

namespace fuzz {

// The form-factor files are read for two facing unit squares of two triangles each (4 patches, 64 bytes of
// values): small, so that a valid file is small and every mutation of it is fast to read.
// tests/fuzz/make_ff_seeds writes the seed files for exactly this mesh.
inline radiosity::Mesh ff_mesh() { return radiosity::two_facing_squares(1); }

// The scene loader's defaults but for the patch limit: the same check, reached 16 times sooner, so that inputs
// which hit it stay fast to run.
inline radiosity::LoadOptions scene_options() {
  radiosity::LoadOptions opt;
  opt.max_patches = 1 << 16;
  return opt;
}

}  // namespace fuzz
