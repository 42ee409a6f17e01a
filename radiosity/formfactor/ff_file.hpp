// The form-factor file: F computed once (the expensive part) and reused for any lighting or reflectivity of the same
// geometry (report §3.6). A file names the mesh it belongs to, so a stale or foreign file is refused, never used.
//
// Layout, little-endian, 72-byte header:
//   0  char[8]  magic "HPCGIFF\0"          40 uint64   mesh_hash(mesh)
//   8  uint32   format version (1)         48 char[8]  hemicube weights, "exact" or "rrv2007", NUL-padded
//   12 uint32   hemicube resolution R      56 float64  threshold
//   16 uint64   patch count n              64 uint64   bytes of values that follow (4·n²)
//   24 char[8]  storage "dense"
//   32 char[8]  value precision "float32"
// then n² float32 values, row-major (F[i*n + j]), then a uint64 checksum of those bytes (FNV-1a over 64-bit words).
// A file's size is therefore known from its header, and a truncated file is told from a corrupted one.
#pragma once
#include <string>

#include "radiosity/formfactor/form_factors.hpp"
#include "radiosity/mesh.hpp"

namespace radiosity {

// Writes path + ".tmp", then renames it to path, so that path is never half-written. Throws std::runtime_error if
// the file cannot be written and std::invalid_argument if ff is not a matrix for this mesh.
void save_form_factors(const std::string& path, const Mesh& mesh, const FormFactors& ff);

// Reads a file written by save_form_factors for the mesh `expected`. Refuses with a UsageError naming the file and
// the reason: it cannot be opened; not a form-factor file (bad magic); an unsupported version, storage or
// precision; a file for another mesh (patch count or hash differ: both are given); a truncated file (expected and
// actual sizes in bytes); a checksum mismatch.
FormFactors load_form_factors(const std::string& path, const Mesh& expected);

}  // namespace radiosity
