// Sparse form factors in the form-factor file (version 2, ff_file.hpp): `formfactors --storage csr|compressed` writes
// the matrix as FormFactorMatrix holds it, and `solve` reads it without ever holding F dense. The payload after the
// 72-byte header, little-endian:
//   uint64 entries, uint64 kept, uint64 bridges, float64 scale (F_ij = scale · stored value; float16: 2^-k)
//   int64  row_start[n + 1]                      (entries of row i: [row_start[i], row_start[i + 1]))
//   csr: int32 col[entries]; compressed: uint16 step[entries]  (ff_matrix.hpp)
//   the values, entries of them: float32, or float16 / bfloat16 bit patterns
// then the payload's checksum (FNV-1a over 64-bit words). Every row is stored (the file belongs to the geometry, not
// to a reflectivity), a kept value is one with |F_ij| > the file's threshold, a bridge's value is 0.
#pragma once
#include <string>

#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"
#include "radiosity/solve/storage/ff_matrix.hpp"

namespace radiosity {

// The payload's bytes for a matrix of these counts.
double sparse_payload_bytes(FFStorage storage, FFValues values, size_t n, size_t entries);

// Writes m (a csr or compressed matrix of every row: built with a reflectivity that needs every row) to path as a
// version 2 file, atomically (common/files.hpp). Throws std::invalid_argument for a dense m or another mesh's.
void save_form_factor_matrix(const std::string& path, const Mesh& mesh, const HemicubeParams& params,
                             const FormFactorMatrix& m);

// Reads a version 2 file for the mesh `expected`: every refusal of load_form_factors (header, mesh, size,
// checksum; a value outside [0, 1] or a stored F_ii other than 0), and a row start, column or step that does not
// describe n rows of increasing columns below n, with one line naming the file. params: the file's hemicube.
FormFactorMatrix load_form_factor_matrix(const std::string& path, const Mesh& expected, HemicubeParams* params);

}  // namespace radiosity
