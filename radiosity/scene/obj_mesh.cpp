// A strict reader for the v/f subset of OBJ. No OBJ library is among the project's dependencies, and the subset
// is two line types; see obj_mesh.hpp.
#include "radiosity/scene/obj_mesh.hpp"

#include <fstream>
#include <sstream>

#include "common/errors.hpp"
#include "common/files.hpp"

namespace radiosity {

std::vector<Triangle> read_obj_triangles(const std::string& path) {
  hpcgi::files::require_input(path, "mesh file");
  std::ifstream in(path);
  if (!in) throw hpcgi::UsageError("cannot read " + path);
  std::vector<Vec3> vertices;
  std::vector<Triangle> triangles;
  std::string line;
  for (size_t lineno = 1; std::getline(in, line); ++lineno) {
    auto fail = [&](const std::string& what) {
      throw hpcgi::UsageError(path + ":" + std::to_string(lineno) + ": " + what);
    };
    std::istringstream ls(line);
    std::string key;
    if (!(ls >> key) || key[0] == '#') continue;
    if (key == "v") {
      Vec3 v;
      if (!(ls >> v.x >> v.y >> v.z)) fail("a vertex needs three numbers");
      vertices.push_back(v);
    } else if (key == "f") {
      long idx[3];
      if (!(ls >> idx[0] >> idx[1] >> idx[2])) fail("a face needs three vertex indices");
      Triangle t;
      for (int k = 0; k < 3; ++k) {
        if (idx[k] < 1 || idx[k] > static_cast<long>(vertices.size()))
          fail("vertex index " + std::to_string(idx[k]) + " is not among the " + std::to_string(vertices.size()) +
               " vertices defined so far");
        t[k] = vertices[idx[k] - 1];
      }
      triangles.push_back(t);
    } else {
      fail("unsupported OBJ keyword '" + key + "' (only v and f are read)");
    }
    std::string rest;
    if (ls >> rest) fail("unexpected '" + rest + "' (only triangles with plain vertex indices are read)");
  }
  if (triangles.empty()) throw hpcgi::UsageError(path + ": no triangles");
  return triangles;
}

}  // namespace radiosity
