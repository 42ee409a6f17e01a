// RRV's built-in primitives in their own frame (unit size, centred at the origin, fronts facing outwards), with
// the vertex and triangle order of RRV 2007 so that patch indices match RRV's: cuboid 12 triangles, barrel 80,
// globe 360 (RRV drops the 2 × 20 degenerate triangles at the poles). The teapot is data: see obj_mesh.hpp.
#pragma once
#include <array>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

using Triangle = std::array<Vec3, 3>;  // the front faces (v1 - v0) × (v2 - v0)

std::vector<Triangle> unit_cuboid();
std::vector<Triangle> unit_barrel();
std::vector<Triangle> unit_globe();

}  // namespace radiosity
