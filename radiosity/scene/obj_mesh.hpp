// Reads the triangle mesh of RRV's teapot primitive from a Wavefront OBJ file (rrv/teapot.obj).
#pragma once
#include <string>
#include <vector>

#include "radiosity/scene/primitives.hpp"

namespace radiosity {

// The triangles of an OBJ file made of `v x y z` and `f a b c` lines (1-based vertex indices) in file order.
// Anything else (other keywords, polygons, texture/normal indices) is refused with hpcgi::UsageError naming the
// line: the one file this reads uses only that subset, and silently skipping data would change the geometry.
std::vector<Triangle> read_obj_triangles(const std::string& path);

}  // namespace radiosity
