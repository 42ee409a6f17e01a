// The light-basis file (`relight --basis FILE`): a basis solved once and read again, refused unless it belongs to
// the same mesh, form factors and colours. Little-endian:
//   0  char[8]  magic "HPCGIRB\0"      40 uint64   scene_colours_hash: emission and reflectivity of every patch
//   8  uint32   format version (1)     48 float64  tol the basis was solved to
//   12 uint32   light count k          56 float64  its largest relative residual
//   16 uint64   patch count n          64 uint64   Jacobi steps of the solve
//   24 uint64   mesh_hash(mesh)        72 then k names, each a uint32 length and its bytes
//   32 uint64   the form-factor file's checksum (its last 8 bytes: F's values as that file holds them)
// then k × n × 3 float64 (light after light, patch-major r, g, b), then a uint64 checksum (radiosity/formfactor/file/format.hpp's Fnv64) of
// every byte before it. Written to FILE.tmp and renamed, so FILE is never half-written.
#pragma once
#include <cstdint>
#include <string>

#include "radiosity/formfactor/file/file.hpp"
#include "radiosity/mesh.hpp"
#include "radiosity/relight/basis.hpp"

namespace radiosity::relight {

// What ties a basis to its inputs.
struct BasisKey {
  size_t n = 0;
  uint64_t mesh = 0, form_factors = 0, colours = 0;
};
// ff: the --ff file (checked against m here), whose stored checksum names F's values.
BasisKey basis_key(const Mesh& m, const FormFactorFile& ff);

// FNV-1a of every patch's emission and reflectivity (bit patterns): a basis holds for these colours only.
uint64_t colours_hash(const Mesh& m);

void save_basis(const std::string& path, const BasisKey& key, const LightBasis& basis);

// Refuses with hpcgi::UsageError naming the file and the reason: cannot be opened, not a basis file, another
// version, another mesh / form-factor file / scene colours (each says which), other lights than `lights`, a
// truncated file, a checksum mismatch.
LightBasis load_basis(const std::string& path, const BasisKey& key, const std::vector<NamedEntity>& lights);

// The basis of relight and web: read from `path` when it exists (refused as load_basis says), else solved on F
// (the --ff file's values) and, when path is not empty, saved there. *loaded says which.
LightBasis load_or_solve_basis(const std::string& path, const Mesh& m, const FormFactorFile& ff,
                               const FFMatrixView& F, const std::vector<NamedEntity>& lights, const BasisOptions& opt,
                               bool* loaded);

}  // namespace radiosity::relight
