// Loads a scene in RRV's XML format (see shared/scenes/FORMAT.md) into the shared Mesh: objectdefs in the head,
// instantiated in the body under nested translate/scale/rotate/shear, triangle strips and the primitives cuboid,
// barrel, globe and teapot, then every triangle subdivided to the maximum patch area like RRV's --divide.
// Patch order is RRV's: entities in the order the body instantiates them, breadth-first within an entity; one
// entity per triangleset or primitive instance, named by its `name` attribute or else "<objectdef>/<element>".
// Bad input throws hpcgi::UsageError with one line "<file>:<line>: <what>".
#pragma once
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

struct LoadOptions {
  double divide = 1.0;  // maximum patch area (RRV's --divide); must be > 0
  // A scene that subdivides into more patches is refused. 2^20 patches would need 4.4 TB for a dense F, far past
  // any machine (the report's largest scene has 17128), while the mesh alone still fits in 160 MB: the limit only
  // stops a huge triangle or a tiny --divide from taking all memory.
  size_t max_patches = size_t(1) << 20;
  // ρ >= 1 in any channel is refused unless this is set: such a surface reflects all the light it receives, so
  // I - diag(ρ)F loses diagonal dominance and a closed scene has no unique solution. RRV's room3.xml has one.
  bool allow_reflectivity_ge_1 = false;
  // Where teapot.obj (the teapot primitive's geometry) is looked for first; empty means the scene file's folder.
  // $RRV_SCENES is looked in second.
  std::string primitive_dir;
};

Mesh load_rrv_scene(const std::string& path, const LoadOptions& opt = {});

// The mesh files the scene at `path` reads beside its XML (the teapot primitive's teapot.obj, as load_rrv_scene
// finds it): inputs of the run, which no output may replace. Empty for a scene that names no teapot, or that does
// not parse (the loader then refuses it).
std::vector<std::string> scene_mesh_files(const std::string& path, const LoadOptions& opt = {});

// The same from XML text; `origin` names it in messages. The teapot is looked for in opt.primitive_dir (if set),
// then $RRV_SCENES.
Mesh load_rrv_scene_string(const std::string& xml, const LoadOptions& opt = {}, const std::string& origin = "<string>");

}  // namespace radiosity
