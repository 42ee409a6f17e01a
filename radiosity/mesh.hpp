// The data every stage of the radiosity pipeline shares: a mesh of triangular patches with their colours.
//   scene/ (RRV XML, generators) -> Mesh -> formfactor/ (hemicube) -> F -> solve/ -> radiosity per patch
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace radiosity {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  double dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
  Vec3 cross(const Vec3& o) const { return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x}; }
  double norm() const { return std::sqrt(dot(*this)); }
  Vec3 normalized() const { return *this * (1.0 / norm()); }
};

// A colour triple (r, g, b): emission, reflectivity ρ or radiosity B per channel.
using Rgb = std::array<double, 3>;

struct Patch {
  std::array<Vec3, 3> v;   // the front faces (v1 - v0) × (v2 - v0)
  Rgb emission{0, 0, 0};   // E
  Rgb reflectivity{0, 0, 0};  // ρ (diffuse, per channel)
  Rgb radiosity{0, 0, 0};  // the scene's radiosity attribute (initial B in RRV)
  int entity = 0;          // index into Mesh::entities: the triangleset or primitive it was cut from

  Vec3 normal() const { return (v[1] - v[0]).cross(v[2] - v[0]).normalized(); }
  double area() const { return 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).norm(); }
  Vec3 centroid() const { return (v[0] + v[1] + v[2]) * (1.0 / 3.0); }
};

struct Mesh {
  std::vector<Patch> patches;          // patch index = order in the file, breadth-first within an entity
  std::vector<std::string> entities;   // one name per triangleset/primitive instance, in file order
  // RRV scenes: per entity, the object instance it belongs to, "OBJECTDEF.K" (the K-th <object> of that objectdef
  // in the body, from 1): the names `bin/radiosity info` lists and `relight` sets lights and reflectivities by.
  // Empty for generated meshes (then an entity is named by its entry in `entities`).
  std::vector<std::string> instances;
  size_t size() const { return patches.size(); }
};

// A 64-bit FNV-1a hash of the patch count and every vertex (bit patterns of the doubles), so that a form-factor
// file can name the mesh it belongs to. Colours are left out on purpose: form factors depend on geometry only, so
// lights and reflectivities may change without recomputing them (report §3.6).
inline uint64_t mesh_hash(const Mesh& m) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* p, size_t n) {
    const unsigned char* c = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ull;
  };
  const uint64_t n = m.patches.size();
  mix(&n, sizeof n);
  for (const Patch& p : m.patches) {
    for (const Vec3& v : p.v) mix(&v, sizeof v);
  }
  return h;
}

}  // namespace radiosity
