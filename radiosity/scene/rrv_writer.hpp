// Writes a mesh and its computed radiosity in RRV's XML format, flattened as RRV writes its output: one objectdef
// named "scene" holding a triangleset per entity, every patch a <triangle> with its emission, reflectivity and
// computed radiosity, and a body that instantiates "scene" once. Reading the file back with a maximum patch area
// at least the one it was made with gives the same patches, in the same order when each entity's patches are
// contiguous (as load_rrv_scene makes them); numbers are written so that they read back bit for bit.
#pragma once
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

// radiosity[i] is patch i's computed B (one per patch, else std::invalid_argument). The file is written to
// a unique temporary file and renamed (common/files.hpp), so nothing half-written is left at `path`; I/O failure
// throws std::runtime_error.
// Entities without patches are left out (RRV's format has no empty triangleset).
void write_rrv_xml(const std::string& path, const Mesh& m, const std::vector<Rgb>& radiosity);

}  // namespace radiosity
