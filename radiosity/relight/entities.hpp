// The names a user sets lights and reflectivities by (`bin/radiosity info` lists them, `relight` and `web` take
// them): an RRV scene's object instances, "OBJECTDEF.K" (the K-th <object> of that objectdef in the body, from 1),
// each with every patch of its shapes. A light is an instance with an emitting patch.
#pragma once
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity::relight {

struct NamedEntity {
  std::string name;
  std::vector<size_t> patches;  // increasing
  bool light = false;           // some patch emits (E > 0 in a channel)
  Rgb emission{0, 0, 0};        // of its first emitting patch (of its first patch when none emits)
  Rgb reflectivity{0, 0, 0};    // of its first patch
  bool uniform_reflectivity = true;  // every patch has that reflectivity
};

// In the order of their first patch. A generated mesh without instance names is named by its entities' names
// (a name given to several entities gets ".K" appended, K from 1, so that every name is one entity).
std::vector<NamedEntity> named_entities(const Mesh& m);

// The lights among them, in the same order.
std::vector<NamedEntity> lights_of(const std::vector<NamedEntity>& named);

// "a, b, c" (at most `limit` names, then ", ... (N in all)").
std::string name_list(const std::vector<NamedEntity>& named, size_t limit = 12);

}  // namespace radiosity::relight
