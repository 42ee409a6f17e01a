// The RRV scene reader: the head's objectdefs are read and checked once (all of them, used or not), then the
// body is walked with a transform stack and every object instance is transformed and subdivided. See
// rrv_reader.hpp for the contract and FORMAT.md for the format.
#include "radiosity/scene/rrv_reader.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "common/errors.hpp"
#include "common/files.hpp"
#include "radiosity/scene/obj_mesh.hpp"
#include "radiosity/scene/primitives.hpp"
#include "radiosity/scene/subdivide.hpp"
#include "radiosity/scene/transform.hpp"
#include "radiosity/scene/xml_input.hpp"

namespace radiosity {

namespace {

// The attributes of a triangle. spec, refl and refr are RRV's ray-tracing attributes: RRV's radiosity ignores
// them but writes them into its output, so they are accepted (and ignored) to read RRV's computed scenes back.
const std::vector<std::string> kSurfaceAttributes = {"emission", "reflectivity", "radiosity", "spec", "refl", "refr"};
// The same plus a name: triangleset and the primitives.
const std::vector<std::string> kEntityAttributes = {"name", "emission", "reflectivity", "radiosity",
                                                    "spec", "refl",     "refr"};

struct Colours {
  Rgb emission{0, 0, 0}, reflectivity{0, 0, 0}, radiosity{0, 0, 0};
};

// One triangleset or primitive of an objectdef, in the objectdef's own frame.
struct Shape {
  std::string name;
  std::vector<Patch> triangles;        // with their colours
  std::vector<pugi::xml_node> source;  // per triangle, the element it came from (for messages)
};

using ObjectDef = std::vector<Shape>;

// Coordinates so large that the edges or the area overflow a double (each number may still be finite): such a
// triangle can be neither judged degenerate nor subdivided.
bool out_of_range(const std::array<Vec3, 3>& v) {
  const Vec3 a = v[1] - v[0], b = v[2] - v[0];
  return !std::isfinite(a.norm()) || !std::isfinite(b.norm()) || !std::isfinite(a.cross(b).norm());
}

// Zero area, judged by the sine of the angle at v0 so that the test does not depend on the scene's scale: the
// three points are collinear (or two coincide) exactly when every angle is 0 or π.
bool degenerate(const std::array<Vec3, 3>& v) {
  const Vec3 a = v[1] - v[0], b = v[2] - v[0];
  return a.cross(b).norm() <= 1e-12 * a.norm() * b.norm();
}

class Reader {
 public:
  Reader(const XmlInput& in, const LoadOptions& opt, std::vector<std::string> teapot_dirs)
      : in_(in), opt_(opt), teapot_dirs_(std::move(teapot_dirs)) {}

  Mesh read() {
    pugi::xml_node scene;
    for (const pugi::xml_node& n : in_.document().children()) {
      if (n.type() != pugi::node_element) continue;
      if (scene || std::strcmp(n.name(), "scene") != 0)
        in_.fail(n, std::string("the document must be one <scene>, found <") + n.name() + ">");
      scene = n;
    }
    if (!scene) throw hpcgi::UsageError(in_.origin() + ": no <scene> element");
    in_.allow_only(scene, {});
    pugi::xml_node head, body;
    for (const pugi::xml_node& n : children(scene)) {
      const bool is_head = std::strcmp(n.name(), "head") == 0;
      if (!is_head && std::strcmp(n.name(), "body") != 0) unknown(n, "<scene> holds <head> and <body>");
      pugi::xml_node& slot = is_head ? head : body;
      if (slot) in_.fail(n, std::string("a second <") + n.name() + ">");
      slot = n;
    }
    if (head) read_head(head);
    if (body) {
      in_.allow_only(body, {});
      walk(body, Transform());
    }
    if (mesh_.patches.empty()) throw hpcgi::UsageError(in_.origin() + ": the scene has no triangles");
    return std::move(mesh_);
  }

 private:
  // The element children of n; text in an element is refused (the format has none).
  std::vector<pugi::xml_node> children(const pugi::xml_node& n) const {
    std::vector<pugi::xml_node> out;
    for (const pugi::xml_node& c : n.children()) {
      if (c.type() == pugi::node_element)
        out.push_back(c);
      else if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata)
        in_.fail(c, std::string("unexpected text in <") + n.name() + ">");
    }
    return out;
  }

  [[noreturn]] void unknown(const pugi::xml_node& n, const std::string& expected) const {
    in_.fail(n, std::string("unknown element <") + n.name() + "> (" + expected + ")");
  }

  void no_children(const pugi::xml_node& n) const {
    if (!children(n).empty()) in_.fail(n, std::string("<") + n.name() + "> takes no child elements");
  }

  // The colours an element sets, each one falling back to `inherited` when absent.
  Colours colours(const pugi::xml_node& n, const Colours& inherited) const {
    Colours c = inherited;
    if (auto e = in_.colour(n, "emission")) c.emission = *e;
    if (auto r = in_.colour(n, "reflectivity")) {
      if (!opt_.allow_reflectivity_ge_1 && ((*r)[0] >= 1 || (*r)[1] >= 1 || (*r)[2] >= 1)) {
        in_.fail(n, std::string("reflectivity \"") + n.attribute("reflectivity").value() +
                        "\" is >= 1 in a channel: such a surface reflects all light it gets and the radiosity "
                        "system may have no unique solution; pass --allow-reflectivity-ge-1 to accept it");
      }
      c.reflectivity = *r;
    }
    if (auto b = in_.colour(n, "radiosity")) c.radiosity = *b;
    return c;
  }

  Vec3 vertex(const pugi::xml_node& n) const {
    if (std::strcmp(n.name(), "vertex") != 0) unknown(n, "expected <vertex>");
    in_.allow_only(n, {"x", "y", "z"});
    no_children(n);
    return {in_.number(n, "x"), in_.number(n, "y"), in_.number(n, "z")};
  }

  static Patch patch(const std::array<Vec3, 3>& v, const Colours& c) {
    Patch p;
    p.v = v;
    p.emission = c.emission;
    p.reflectivity = c.reflectivity;
    p.radiosity = c.radiosity;
    return p;
  }

  void add(Shape& s, const std::array<Vec3, 3>& v, const Colours& c, const pugi::xml_node& source) const {
    if (out_of_range(v)) in_.fail(source, "triangle out of range (its size overflows a double)");
    if (degenerate(v)) in_.fail(source, "degenerate triangle (zero area)");
    s.triangles.push_back(patch(v, c));
    s.source.push_back(source);
  }

  // triangle restarts a strip; the k-th trianglenext after it moves slot 1 to 0 and puts the new vertex in slot 1
  // (k odd) or moves slot 2 to 0 and puts it in slot 2 (k even), as RRV does.
  Shape triangleset(const pugi::xml_node& set, const std::string& name) const {
    in_.allow_only(set, kEntityAttributes);
    Shape s{name, {}, {}};
    const Colours set_colours = colours(set, Colours{});
    Colours current;
    std::array<Vec3, 3> v;
    bool odd_next = true;
    for (const pugi::xml_node& n : children(set)) {
      const bool restart = std::strcmp(n.name(), "triangle") == 0;
      if (!restart && std::strcmp(n.name(), "trianglenext") != 0)
        unknown(n, "a <triangleset> holds <triangle> and <trianglenext>");
      in_.allow_only(n, kSurfaceAttributes);
      const std::vector<pugi::xml_node> vs = children(n);
      if (restart) {
        if (vs.size() != 3) in_.fail(n, "<triangle> needs exactly 3 <vertex>, found " + std::to_string(vs.size()));
        v = {vertex(vs[0]), vertex(vs[1]), vertex(vs[2])};
        current = colours(n, set_colours);
        odd_next = true;
      } else {
        if (s.triangles.empty()) in_.fail(n, "<trianglenext> must follow a <triangle>");
        if (vs.size() != 1) in_.fail(n, "<trianglenext> needs exactly 1 <vertex>, found " + std::to_string(vs.size()));
        const int slot = odd_next ? 1 : 2;
        v[0] = v[slot];
        v[slot] = vertex(vs[0]);
        // RRV keeps the strip's colours; the element's own attributes, if any, override them.
        current = colours(n, current);
        odd_next = !odd_next;
      }
      add(s, v, current, n);
    }
    if (s.triangles.empty()) in_.fail(set, "<triangleset> has no triangles");
    return s;
  }

  Shape primitive(const pugi::xml_node& n, const std::string& name) {
    in_.allow_only(n, kEntityAttributes);
    no_children(n);
    const std::string kind = n.name();
    const std::vector<Triangle> geometry = kind == "cuboid"   ? unit_cuboid()
                                           : kind == "barrel" ? unit_barrel()
                                           : kind == "globe"  ? unit_globe()
                                                              : teapot(n);
    const Colours c = colours(n, Colours{});
    Shape s{name, {}, {}};
    for (const Triangle& t : geometry) add(s, t, c, n);
    return s;
  }

  const std::vector<Triangle>& teapot(const pugi::xml_node& n) {
    if (teapot_) return *teapot_;
    std::string searched;
    for (const std::string& dir : teapot_dirs_) {
      const std::filesystem::path file = std::filesystem::path(dir) / "teapot.obj";
      if (std::filesystem::is_regular_file(file)) return teapot_.emplace(read_obj_triangles(file.string()));
      searched += (searched.empty() ? "" : ", ") + dir;
    }
    in_.fail(n, "the teapot primitive needs RRV's teapot.obj, not found in " +
                    (searched.empty() ? std::string("any folder") : searched) +
                    " (set RRV_SCENES to the folder that holds it)");
  }

  void read_head(const pugi::xml_node& head) {
    in_.allow_only(head, {});
    for (const pugi::xml_node& def : children(head)) {
      if (std::strcmp(def.name(), "objectdef") != 0) unknown(def, "<head> holds <objectdef>");
      in_.allow_only(def, {"name"});
      const std::string name = in_.text(def, "name");
      if (defs_.count(name)) in_.fail(def, "objectdef '" + name + "' is defined twice");
      ObjectDef shapes;
      for (const pugi::xml_node& n : children(def)) {
        const std::string kind = n.name();
        const std::string shape_name = n.attribute("name") ? n.attribute("name").value() : name + "/" + kind;
        if (kind == "triangleset")
          shapes.push_back(triangleset(n, shape_name));
        else if (kind == "cuboid" || kind == "barrel" || kind == "globe" || kind == "teapot")
          shapes.push_back(primitive(n, shape_name));
        else
          in_.fail(n,
                   "unknown primitive <" + kind + "> (an objectdef holds triangleset, cuboid, barrel, globe, teapot)");
      }
      if (shapes.empty()) in_.fail(def, "objectdef '" + name + "' is empty");
      defs_.emplace(name, std::move(shapes));
    }
  }

  // Transforms nest; the depth is bounded so that a hostile file cannot exhaust the stack (RRV's scenes nest 4 deep).
  static constexpr int kMaxNesting = 1000;
  void walk(const pugi::xml_node& parent, const Transform& m, int depth = 0) {
    if (depth > kMaxNesting)
      in_.fail(parent, "transforms nested more than " + std::to_string(kMaxNesting) + " deep (a scene needs a few)");
    for (const pugi::xml_node& n : children(parent)) {
      const std::string kind = n.name();
      if (kind == "object") {
        in_.allow_only(n, {"name"});
        no_children(n);
        const std::string name = in_.text(n, "name");
        const auto def = defs_.find(name);
        if (def == defs_.end()) in_.fail(n, "object '" + name + "' names no objectdef of the head");
        instantiate(def->second, m, n);
      } else if (kind == "translate" || kind == "scale") {
        // RRV reads a missing component as 0, also for scale (FORMAT.md).
        in_.allow_only(n, {"dx", "dy", "dz"});
        const Vec3 d{in_.number(n, "dx", 0.0), in_.number(n, "dy", 0.0), in_.number(n, "dz", 0.0)};
        walk(n, kind == "translate" ? m.translated(d) : m.scaled(d), depth + 1);
      } else if (kind == "rotate") {
        in_.allow_only(n, {"angle", "dx", "dy", "dz"});
        const Vec3 axis{in_.number(n, "dx", 0.0), in_.number(n, "dy", 0.0), in_.number(n, "dz", 0.0)};
        const double angle = in_.number(n, "angle");
        if (axis.norm() == 0) in_.fail(n, "<rotate> needs a non-zero axis dx, dy, dz");
        walk(n, m.rotated(angle, axis), depth + 1);
      } else if (kind == "shear") {
        in_.allow_only(n, {"dx", "dy", "dz"});
        walk(n, m, depth + 1);  // RRV's shear has no effect
      } else {
        unknown(n, "the body holds object, translate, scale, rotate, shear");
      }
    }
  }

  void instantiate(const ObjectDef& def, const Transform& m, const pugi::xml_node& object) {
    const std::string def_name = in_.text(object, "name");
    const std::string instance = def_name + "." + std::to_string(++instances_[def_name]);
    for (const Shape& s : def) {
      std::vector<Patch> placed = s.triangles;
      for (size_t k = 0; k < placed.size(); ++k) {
        Patch& p = placed[k];
        for (Vec3& v : p.v) v = m.apply(v);
        if (out_of_range(p.v))
          in_.fail(s.source[k], "triangle of '" + s.name + "' is out of range after the transforms of the object " +
                                    "at line " + std::to_string(in_.line(object)) + " (its size overflows a double)");
        if (degenerate(p.v))
          in_.fail(s.source[k],
                   "triangle of '" + s.name + "' has zero area after the transforms of the object at line " +
                       std::to_string(in_.line(object)) + " (a scale that names only some axes sets the others to 0)");
        p.entity = static_cast<int>(mesh_.entities.size());
      }
      const std::optional<std::vector<Patch>> patches =
          subdivide(placed, opt_.divide, opt_.max_patches - mesh_.patches.size());
      if (!patches)
        in_.fail(object, "the scene subdivides into more than " + std::to_string(opt_.max_patches) +
                             " patches at a maximum patch area of " + (std::ostringstream() << opt_.divide).str() +
                             " (reached at '" + s.name + "'); use a larger --divide");
      mesh_.patches.insert(mesh_.patches.end(), patches->begin(), patches->end());
      mesh_.entities.push_back(s.name);
      mesh_.instances.push_back(instance);
    }
  }

  const XmlInput& in_;
  const LoadOptions& opt_;
  const std::vector<std::string> teapot_dirs_;
  std::map<std::string, ObjectDef> defs_;
  std::map<std::string, int> instances_;  // <object>s of each objectdef so far
  std::optional<std::vector<Triangle>> teapot_;
  Mesh mesh_;
};

// Where the teapot primitive's teapot.obj is looked for, in order: `first` (empty: nowhere), then $RRV_SCENES.
std::vector<std::string> teapot_dirs(const std::string& first) {
  std::vector<std::string> dirs;
  if (!first.empty()) dirs.push_back(first);
  if (const char* env = std::getenv("RRV_SCENES"); env && *env) dirs.emplace_back(env);
  return dirs;
}

// A scene file's first folder to look in: the primitive folder if given, else the scene file's own.
std::string file_teapot_dir(const std::string& path, const LoadOptions& opt) {
  const std::string folder = std::filesystem::path(path).parent_path().string();
  return opt.primitive_dir.empty() ? (folder.empty() ? "." : folder) : opt.primitive_dir;
}

Mesh load(const XmlInput& in, const LoadOptions& opt, const std::vector<std::string>& dirs) {
  if (!(opt.divide > 0) || !std::isfinite(opt.divide))
    throw hpcgi::UsageError("the maximum patch area (--divide) must be a positive number, got " +
                            std::to_string(opt.divide));
  return Reader(in, opt, dirs).read();
}

}  // namespace

Mesh load_rrv_scene(const std::string& path, const LoadOptions& opt) {
  hpcgi::files::require_input(path, "scene file");  // a FIFO would block the run for ever
  std::ifstream f(path, std::ios::binary);
  if (!f) throw hpcgi::UsageError("cannot read scene file " + path + ": " + std::strerror(errno));
  std::ostringstream text;
  text << f.rdbuf();
  const XmlInput in(text.str(), path);
  return load(in, opt, teapot_dirs(file_teapot_dir(path, opt)));
}

Mesh load_rrv_scene_string(const std::string& xml, const LoadOptions& opt, const std::string& origin) {
  const XmlInput in(xml, origin);
  return load(in, opt, teapot_dirs(opt.primitive_dir));
}

std::vector<std::string> scene_mesh_files(const std::string& path, const LoadOptions& opt) {
  pugi::xml_document doc;
  if (!doc.load_file(path.c_str())) return {};  // the loader refuses it in its words
  if (!doc.find_node([](const pugi::xml_node& n) { return std::strcmp(n.name(), "teapot") == 0; })) return {};
  for (const std::string& dir : teapot_dirs(file_teapot_dir(path, opt))) {
    const std::filesystem::path file = std::filesystem::path(dir) / "teapot.obj";
    if (std::filesystem::is_regular_file(file)) return {file.string()};
  }
  return {};
}

}  // namespace radiosity
