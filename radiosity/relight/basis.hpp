// The light basis (issue 20): B is linear in E, so with the form factors and reflectivities fixed the radiosity of
// any mix of the lights' intensities and colours is the same mix of one solution per light, channel by channel:
//   E = Σ_l s_l c_l ⊙ E_l   =>   B = Σ_l s_l c_l ⊙ B_l,   A B_l = E_l  (A_c = I - diag(ρ_c) F),
// E_l the scene's emission on light l's patches (0 elsewhere), s_l its intensity and c_l its colour. The k solves
// run together, Jacobi in float64 with all k right-hand sides in one pass over F per step (the driver's solve_multi:
// methods/multi_rhs.hpp over the k-product of the backend, serial, openmp or mpi), until every light's every channel
// has a relative residual <= tol. A frame is then
// O(patches × lights), exact up to the basis' own residual.
#pragma once
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/relight/entities.hpp"
#include "radiosity/solve/config/config.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity::relight {

// A light's setting in a frame: its emission is intensity × colour ⊙ the scene's emission of its patches.
struct LightSetting {
  double intensity = 1;
  Rgb colour{1, 1, 1};
};

struct LightBasis {
  size_t n = 0;
  std::vector<std::string> lights;     // names, in the order of `B`
  std::vector<std::vector<double>> B;  // per light: n × 3, patch-major (r, g, b of patch 0, then patch 1, ...)
  std::vector<float> packed;           // the same as float, light after light: what a frame reads (pack())
  long iterations = 0;                 // Jacobi steps of the solve (0 when read from a file)
  double tol = 0;
  double max_residual = 0;             // over lights and channels: ‖E_l - A B_l‖ / ‖E_l‖ (absolute where E_l,c = 0)
  double seconds = 0;
  void pack();
};

struct BasisOptions {
  double tol = 1e-7;
  long max_iter = 100000;
  int threads = 0;  // 0: the OpenMP default
  std::string backend = "openmp";  // a backend with a k-right-hand-side product (multi_solve.hpp)
};

// The driver's configuration of the basis's solve (solve_multi): what relight's plan checks (check_config) before
// anything is read.
SolveConfig basis_config(const BasisOptions& opt);

// Solves the basis of these lights on the mesh's reflectivities and dense F (any stored values; the relighting
// uses the file's float32). Throws hpcgi::NumericalError when a light's solve does not converge (Jacobi needs
// ρ F to contract) and hpcgi::UsageError for a scene without lights.
LightBasis solve_light_basis(const Mesh& m, const FFMatrixView& F, const std::vector<NamedEntity>& lights,
                             const BasisOptions& opt);

// out (n × 3, patch-major) = Σ_l s_l c_l ⊙ B_l from basis.packed: the frame of these settings (one per light).
void mix(const LightBasis& basis, const std::vector<LightSetting>& settings, std::vector<float>& out, int threads);

// The emission of a frame: intensity × colour ⊙ the scene's emission on each light's patches, the scene's elsewhere.
std::vector<Rgb> frame_emission(const Mesh& m, const std::vector<NamedEntity>& lights,
                                const std::vector<LightSetting>& settings);

}  // namespace radiosity::relight
