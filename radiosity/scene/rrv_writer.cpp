// RRV-format output with pugixml; see rrv_writer.hpp.
#include "radiosity/scene/rrv_writer.hpp"
#include "common/files.hpp"

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <pugixml.hpp>
#include <stdexcept>
#include <system_error>

namespace radiosity {

namespace {

// The shortest text that reads back as the same double.
std::string number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string colour(const Rgb& c) { return number(c[0]) + "," + number(c[1]) + "," + number(c[2]); }

}  // namespace

void write_rrv_xml(const std::string& path, const Mesh& m, const std::vector<Rgb>& radiosity) {
  if (radiosity.size() != m.size())
    throw std::invalid_argument("write_rrv_xml: " + std::to_string(radiosity.size()) + " radiosities for " +
                                std::to_string(m.size()) + " patches");
  std::vector<std::vector<size_t>> by_entity(m.entities.size());
  for (size_t i = 0; i < m.size(); ++i) {
    const int e = m.patches[i].entity;
    if (e < 0 || static_cast<size_t>(e) >= m.entities.size())
      throw std::invalid_argument("write_rrv_xml: patch " + std::to_string(i) + " names entity " + std::to_string(e) +
                                  " of " + std::to_string(m.entities.size()));
    by_entity[e].push_back(i);
  }

  pugi::xml_document doc;
  pugi::xml_node decl = doc.append_child(pugi::node_declaration);
  decl.append_attribute("version") = "1.0";
  decl.append_attribute("encoding") = "utf-8";
  pugi::xml_node scene = doc.append_child("scene");
  pugi::xml_node def = scene.append_child("head").append_child("objectdef");
  def.append_attribute("name") = "scene";
  for (size_t e = 0; e < by_entity.size(); ++e) {
    if (by_entity[e].empty()) continue;
    pugi::xml_node set = def.append_child("triangleset");
    set.append_attribute("name") = m.entities[e].c_str();
    for (size_t i : by_entity[e]) {
      const Patch& p = m.patches[i];
      pugi::xml_node t = set.append_child("triangle");
      t.append_attribute("emission") = colour(p.emission).c_str();
      t.append_attribute("reflectivity") = colour(p.reflectivity).c_str();
      t.append_attribute("radiosity") = colour(radiosity[i]).c_str();
      for (const Vec3& v : p.v) {
        pugi::xml_node x = t.append_child("vertex");
        x.append_attribute("x") = number(v.x).c_str();
        x.append_attribute("y") = number(v.y).c_str();
        x.append_attribute("z") = number(v.z).c_str();
      }
    }
  }
  scene.append_child("body").append_child("object").append_attribute("name") = "scene";

  hpcgi::files::AtomicFile out(path);  // a unique temporary file beside it, renamed over it when whole
  pugi::xml_writer_file writer(out.stream());
  doc.save(writer, "  ");
  out.commit();
}

}  // namespace radiosity
