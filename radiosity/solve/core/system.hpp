// The linear system every solver takes (report eqs. 2.3-2.6): B = E + ρ ⊙ (F B) per colour channel c, that is
// A_c b_c = e_c with A_c = I - diag(ρ_c) F. The form-factor matrix F is shared by the three channels.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity {

struct System {
  size_t n = 0;
  // F, the form-factor matrix, as a view of the one FormFactorMatrix that holds it (or of values the caller owns):
  // any storage (ff_matrix.hpp); dense float32 is the file's layout, F_ij at i*n + j, F_ii = 0. matrix.n = n (its
  // data may be null for a CSR matrix that keeps nothing); only the backends that read its storage run it
  // (SolveBackend::storages).
  FFMatrixView matrix;
  std::vector<Rgb> emission;       // E, n entries
  std::vector<Rgb> reflectivity;   // ρ, n entries
  std::vector<Rgb> initial;        // B0, n entries (RRV: rrv_initial_radiosity)
  // An MPI rank's system (backend mpi): F holds only rows [rows_begin, rows_end); a dense matrix row i at
  // (i - rows_begin)·n, a csr or compressed one indexes every row, the others empty (ff_matrix.hpp);
  // the vectors are whole. rows_end = SIZE_MAX: F holds every row.
  size_t rows_begin = 0, rows_end = SIZE_MAX;
};

// Whether F holds every row (any backend runs the system) or only a rank's block (backend mpi only).
inline bool holds_all_rows(const System& sys) {
  return sys.rows_end == SIZE_MAX || (sys.rows_begin == 0 && sys.rows_end == sys.n);
}

// RRV's starting radiosity: B0 = max(radiosity attribute, emission), channel by channel.
std::vector<Rgb> rrv_initial_radiosity(const std::vector<Rgb>& attribute, const std::vector<Rgb>& emission);

// The system of a mesh whose form factors are F (n = mesh.size()), starting from RRV's B0.
System make_system(const Mesh& mesh, const FFMatrixView& F);
// The same on n×n dense float32 values (a view of them: they stay the caller's).
System make_system(const Mesh& mesh, const float* F);

// The system's form factors as the kernels read them (sys.matrix).
inline const FFMatrixView& system_matrix(const System& sys) { return sys.matrix; }

// The matrix's values when it is dense float32 (the file's layout, what the dense-only backends read), else null.
inline const float* dense_float32(const System& sys) {
  return sys.matrix.storage == FFStorage::dense && sys.matrix.values == FFValues::float32
             ? static_cast<const float*>(sys.matrix.data)
             : nullptr;
}

// Whether every emission, reflectivity and starting radiosity has r = g = b: then the three channels are one solve.
bool is_grey(const System& sys);

// Throws hpcgi::UsageError if the sizes disagree, F is missing or there are no patches. Values are not checked:
// a NaN in the input is the solver's to report (status nonfinite), not a usage error.
void check_system(const System& sys);

// ‖e_c‖₂² per channel.
Rgb emission_norm2(const System& sys);

// The denominator of the relative residual per channel: ‖e_c‖₂, or 1 where e_c = 0. A channel without emission
// has the solution b_c = 0 and no scale of its own, so its residual is measured absolutely: ‖A_c b_c‖₂ ≤ tol.
Rgb residual_scale(const System& sys);

// ‖e_c - A_c b_c‖₂ / residual_scale_c per channel, computed in double from B whatever precision produced it (the
// independent check every backend's answer gets; OpenMP threads over rows), on system_matrix(sys). The system must
// hold every row of F; an MPI rank adds up residual_squares of its rows with the other ranks'.
Rgb relative_residual(const System& sys, const std::vector<Rgb>& B);

// Σ_i (e_ic - (A_c b_c)_i)² per channel over the rows of F the system holds (all of them, or a rank's block).
Rgb residual_squares(const System& sys, const std::vector<Rgb>& B);

}  // namespace radiosity
