// The reference a solve's error is measured against (result.error_vs_reference): the float64 solution of a
// system converged to a relative residual of 1e-12, by default on the very form factors of the run before any
// threshold, 16-bit rounding or early stop, so that the error is what those choices cost. For the accuracy of the
// form factors themselves, the reference may come from another form-factor file of the same mesh (a finer
// hemicube) or from a finer mesh of the same scene, carried onto this mesh by area-weighted means (mesh_map.hpp).
#pragma once
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/core/system.hpp"

namespace radiosity::app {

inline constexpr double kReferenceTol = 1e-12;

struct ErrorReference {
  std::vector<Rgb> B;         // on the run's mesh
  std::string of;             // what it was solved from, in words
  std::string method;         // bicgstab, or jacobi where BiCG-STAB broke down
  long iterations = 0;
  double max_rel_residual = 0;
  bool converged = false;     // false: B is the best it reached, and the error against it is no error bound
  size_t patches = 0;         // of the mesh it was solved on
  double seconds = 0;
};

// The float64 solution of sys to kReferenceTol (openmp, all threads): BiCG-STAB (a few dozen matrix passes where
// Jacobi needs hundreds when ρ is near 1), and Jacobi (up to 100000 steps) if BiCG-STAB breaks down or stalls.
ErrorReference converged_reference(const System& sys, const std::string& of);

// max over patches and channels of |B - R|, over the largest |R| (|B - R| itself where R is 0 everywhere, as
// for a scene without light).
double max_rel_diff(const std::vector<Rgb>& B, const std::vector<Rgb>& R);

}  // namespace radiosity::app
