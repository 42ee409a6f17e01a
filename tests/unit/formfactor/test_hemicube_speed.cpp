// A timing, not a check: disabled so that the suite stays fast. Run it with
//   OMP_NUM_THREADS=2 build/tests/formfactor_tests --gtest_also_run_disabled_tests --gtest_filter='HemicubeSpeed.*'
// A closed cube of 17 × 17 cells per face (3468 patches, about the report's scene 2) at the default R = 256: every
// hemicube pixel is covered, so each patch costs the full raster and gather work.
#include <gtest/gtest.h>
#include <omp.h>

#include <chrono>
#include <cstdio>

#include "radiosity/formfactor/hemicube.hpp"
#include "radiosity/scene/analytic.hpp"

using namespace radiosity;

TEST(HemicubeSpeed, DISABLED_ClosedCube3468PatchesAtDefaultResolution) {
  const Mesh cube = closed_unit_cube(17, {0.5, 0.5, 0.5}, {0, 0, 0});
  for (HemicubeWeights w : {HemicubeWeights::exact, HemicubeWeights::rrv2007}) {
    const auto start = std::chrono::steady_clock::now();
    const FormFactors F = compute_form_factors(cube, {256, w, 0}, stderr_progress());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("hemicube %s: %zu patches, R = 256, %d threads: %.2f s, %.0f patches/s\n", to_string(w).c_str(),
                F.n, omp_get_max_threads(), s, F.n / s);
  }
}
