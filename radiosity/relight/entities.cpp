#include "radiosity/relight/entities.hpp"

#include <map>

#include "common/one_line.hpp"

namespace radiosity::relight {

std::vector<NamedEntity> named_entities(const Mesh& m) {
  // The name of each entity: its instance, or (generated meshes) its own name, numbered where it repeats.
  std::vector<std::string> names(m.entities.size());
  if (m.instances.size() == m.entities.size()) {
    names = m.instances;
  } else {
    std::map<std::string, int> count, seen;
    for (const std::string& e : m.entities) ++count[e];
    for (size_t i = 0; i < m.entities.size(); ++i)
      names[i] = count[m.entities[i]] > 1 ? m.entities[i] + "." + std::to_string(++seen[m.entities[i]]) : m.entities[i];
  }
  std::vector<NamedEntity> out;
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < m.patches.size(); ++i) {
    const Patch& p = m.patches[i];
    const std::string& name = p.entity >= 0 && size_t(p.entity) < names.size() ? names[p.entity] : m.entities.at(0);
    auto [it, fresh] = index.emplace(name, out.size());
    if (fresh) {
      NamedEntity e;
      e.name = name;
      e.emission = p.emission;
      e.reflectivity = p.reflectivity;
      out.push_back(e);
    }
    NamedEntity& e = out[it->second];
    const bool emits = p.emission[0] > 0 || p.emission[1] > 0 || p.emission[2] > 0;
    if (emits && !e.light) e.emission = p.emission;
    e.light = e.light || emits;
    e.uniform_reflectivity = e.uniform_reflectivity && p.reflectivity == e.reflectivity;
    e.patches.push_back(i);
  }
  return out;
}

std::vector<NamedEntity> lights_of(const std::vector<NamedEntity>& named) {
  std::vector<NamedEntity> out;
  for (const NamedEntity& e : named)
    if (e.light) out.push_back(e);
  return out;
}

std::string name_list(const std::vector<NamedEntity>& named, size_t limit) {
  std::string s;
  for (size_t i = 0; i < named.size() && i < limit; ++i) s += (i ? ", " : "") + hpcgi::one_line(named[i].name, 100);
  if (named.size() > limit) s += ", ... (" + std::to_string(named.size()) + " in all)";
  return s.empty() ? "none" : s;
}

}  // namespace radiosity::relight
