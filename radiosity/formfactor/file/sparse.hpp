// Sparse form factors in the form-factor file (version 2, format.hpp): `formfactors --storage csr|compressed|runs` writes
// the matrix as FormFactorMatrix holds it, and `solve` reads it without ever holding F dense. The payload after the
// 72-byte header, little-endian:
//   uint64 entries, uint64 kept, uint64 bridges, float64 scale (F_ij = scale · stored value; float16: 2^-k)
//   runs: uint64 runs (entries counts the kept values and the zeros of merged gaps, bridges the runs of length 0)
//   int64  row_start[n + 1]                      (entries of row i: [row_start[i], row_start[i + 1]))
//   csr: int32 col[entries]; compressed: uint16 step[entries]  (ff_matrix.hpp)
//   runs: int64 run_start[n + 1], then the runs, {uint16 step, uint16 length} each (ff_matrix.hpp's FFRun)
//   the values, entries of them: float32, or float16 / bfloat16 bit patterns
// then the payload's checksum (FNV-1a over 64-bit words). Every row is stored (the file belongs to the geometry, not
// to a reflectivity), a kept value is one with |F_ij| > the file's threshold, a bridge's value is 0.
#pragma once
#include <string>

#include "radiosity/formfactor/file/format.hpp"
#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity {

// The payload's bytes for a matrix of these counts (runs: runs of them).
double sparse_payload_bytes(FFStorage storage, FFValues values, size_t n, size_t entries, size_t runs = 0);

// Writes m (a csr, compressed or runs matrix of every row: built with a reflectivity that needs every row) to path as a
// version 2 file, atomically (common/files.hpp). Throws std::invalid_argument for a dense m or another mesh's.
void save_form_factor_matrix(const std::string& path, const Mesh& mesh, const HemicubeParams& params,
                             const FormFactorMatrix& m);

// Reads a version 2 file for the mesh `expected`: every refusal of load_form_factors (header, mesh, size,
// checksum; a value outside [0, 1] or a stored F_ii other than 0), and a row start, column, step or run that does
// not describe n rows of increasing columns below n, with one line naming the file. params: the file's hemicube.
FormFactorMatrix load_form_factor_matrix(const std::string& path, const Mesh& expected, HemicubeParams* params);
// The same on a version 2 file whose header was read and checked once already (info: check_any_form_factor_file's).
FormFactorMatrix load_form_factor_matrix(const std::string& path, const FormFactorFileInfo& info);

}  // namespace radiosity
