#include "radiosity/relight/frames.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/one_line.hpp"

namespace radiosity::relight {
namespace {

// Line, column and frame index of byte `at` of a {"frames": [...]} document (the frame: objects opened at depth 2).
std::string where(const std::string& text, size_t at) {
  size_t line = 1, col = 1;
  int depth = 0;
  long frame = -1;
  bool in_string = false, escaped = false;
  for (size_t i = 0; i < at && i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') ++line, col = 1;
    else ++col;
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '{' || c == '[') {
      if (c == '{' && depth == 2) ++frame;
      ++depth;
    } else if (c == '}' || c == ']') --depth;
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(col) +
         (frame >= 0 ? " (frame " + std::to_string(frame) + ")" : "");
}

double number(const nlohmann::json& v, const std::string& what) {
  if (!v.is_number()) throw hpcgi::UsageError(what + " is not a number (" + v.dump() + ")");
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw hpcgi::UsageError(what + " is not finite");
  if (x < 0) throw hpcgi::UsageError(what + " is negative (" + v.dump() + ")");
  return x;
}

Rgb triple(const nlohmann::json& v, const std::string& what) {
  if (!v.is_array() || v.size() != 3) throw hpcgi::UsageError(what + " must be three numbers [r, g, b], got " + v.dump());
  Rgb c;
  for (int i = 0; i < 3; ++i) c[i] = number(v[i], what + "[" + std::to_string(i) + "]");
  return c;
}

// The frames file's JSON, refused with one line "FILE: ..." when larger than kMaxFramesFileBytes or malformed.
nlohmann::json parse_frames_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw hpcgi::UsageError(path + ": cannot open the frames file");
  std::string text;
  std::vector<char> chunk(size_t(1) << 16);
  while (f.read(chunk.data(), std::streamsize(chunk.size())) || f.gcount() > 0)
    if (text.append(chunk.data(), size_t(f.gcount())).size() > kMaxFramesFileBytes)
      throw hpcgi::UsageError(path + ": a frames file of more than " + hpcgi::format_bytes(double(kMaxFramesFileBytes)) +
                            " (at most " + std::to_string(kMaxFrames) + " frames)");
  nlohmann::json doc;
  // A key given twice in one object is refused: the parser would keep the last, silently (issue 48).
  std::vector<std::vector<std::string>> keys;
  const auto once = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using E = nlohmann::json::parse_event_t;
    if (event == E::object_start) keys.emplace_back();
    if (event == E::object_end && !keys.empty()) keys.pop_back();
    if (event == E::key && !keys.empty()) {
      const std::string k = parsed.get<std::string>();
      if (std::find(keys.back().begin(), keys.back().end(), k) != keys.back().end())
        throw hpcgi::UsageError(path + ": the key '" + hpcgi::one_line(k, 80) + "' is given twice in one object");
      keys.back().push_back(k);
    }
    return true;
  };
  try {
    doc = nlohmann::json::parse(text, once);
  } catch (const nlohmann::json::parse_error& e) {
    std::string why = e.what();  // "[json.exception.parse_error.101] parse error at line L, column C: WHY"
    const size_t col = why.find("column");
    const size_t colon = why.find(": ", col == std::string::npos ? 0 : col);
    if (colon != std::string::npos) why = why.substr(colon + 2);
    throw hpcgi::UsageError(path + ": malformed JSON at " + where(text, e.byte > 0 ? e.byte - 1 : 0) + ": " + why +
                            " (NaN and Infinity are not JSON)");
  } catch (const nlohmann::json::out_of_range& e) {  // a number beyond double, e.g. 1e999: "... parsing 'LITERAL'"
    std::string why = e.what();
    const size_t q0 = why.find('\''), q1 = why.rfind('\'');
    const std::string literal = q0 < q1 ? why.substr(q0 + 1, q1 - q0 - 1) : "";
    const size_t at = literal.empty() ? std::string::npos : text.find(literal);
    throw hpcgi::UsageError(path + ": number out of range" +
                            (at != std::string::npos ? " at " + where(text, at) : std::string()) + ": " + literal +
                            " is not finite as a double");
  }
  return doc;
}

// What each frame of a frames file is read against: the scene's named entities and its lights, their indexes by
// name, and each patch's reflectivity in the scene.
struct FrameNames {
  const std::vector<NamedEntity>& named;
  std::vector<NamedEntity> lights;
  std::map<std::string, size_t> light_index, entity_index;
  std::vector<Rgb> scene_rho;
  bool allow_reflectivity_ge_1;
};

// A frame's "lights": {NAME: {"intensity": x, "rgb": [r, g, b]}}, into the lights of state (unnamed lights and
// fields keep their values from the frame before).
void read_lights(const nlohmann::json& value, const FrameNames& s, Frame& state) {
  if (!value.is_object()) throw hpcgi::UsageError("\"lights\" must be an object {NAME: {\"intensity\", \"rgb\"}}");
  for (const auto& [key, setting] : value.items()) {
    const std::string name = hpcgi::one_line(key, 80);  // as shown: a NUL or an escape in the file's key stays visible
    const auto it = s.light_index.find(key);
    if (it == s.light_index.end())
      throw hpcgi::UsageError("unknown light '" + name + "' (lights: " + name_list(s.lights) + ")");
    if (!setting.is_object())
      throw hpcgi::UsageError("light '" + name + "' must be {\"intensity\": x, \"rgb\": [r, g, b]}");
    LightSetting& ls = state.lights[it->second];
    for (const auto& [field, v] : setting.items()) {
      if (field == "intensity") ls.intensity = number(v, "light '" + name + "' intensity");
      else if (field == "rgb") ls.colour = triple(v, "light '" + name + "' rgb");
      else throw hpcgi::UsageError("light '" + name + "': unknown key '" + hpcgi::one_line(field, 40) + "' (intensity, rgb)");
    }
  }
}

// Entity e's reflectivity {"scale": f}: the scene's reflectivity of its patches times f, refused where that
// reaches 1 in a channel of a patch (unless allowed).
void read_scale(const nlohmann::json& v, const std::string& what, size_t e, const FrameNames& s,
                FrameReflectivity& rho) {
  if (v.size() != 1 || !v.contains("scale"))
    throw hpcgi::UsageError(what + " must be [r, g, b] or {\"scale\": f}, got " + v.dump());
  const double f = number(v["scale"], what + " scale");
  double top = 0;
  for (size_t i : s.named[e].patches)
    for (int c = 0; c < 3; ++c) top = std::max(top, s.scene_rho[i][c] * f);
  if (top >= 1 && !s.allow_reflectivity_ge_1)
    throw hpcgi::UsageError(what + " times " + v["scale"].dump() + " is >= 1 in a channel of a patch (" +
                            std::to_string(top) + "); give --allow-reflectivity-ge-1 to accept it");
  rho.reflectivity[e] = std::nullopt;
  rho.scale[e] = f;
}

// A frame's "reflectivity": {NAME: [r, g, b] or {"scale": f}}, into rho (the entities not named keep theirs).
void read_reflectivity(const nlohmann::json& value, const FrameNames& s, FrameReflectivity& rho) {
  if (!value.is_object()) throw hpcgi::UsageError("\"reflectivity\" must be an object {NAME: [r, g, b]}");
  for (const auto& [key, v] : value.items()) {
    const std::string name = hpcgi::one_line(key, 80);  // as shown: a NUL or an escape in the file's key stays visible
    const auto it = s.entity_index.find(key);
    if (it == s.entity_index.end())
      throw hpcgi::UsageError("unknown entity '" + name + "' (entities: " + name_list(s.named) + ")");
    const std::string what = "reflectivity of '" + name + "'";
    if (v.is_object()) {
      read_scale(v, what, it->second, s, rho);
      continue;
    }
    const Rgb c = triple(v, what);
    for (int ch = 0; ch < 3; ++ch)
      if (c[ch] >= 1 && !s.allow_reflectivity_ge_1)
        throw hpcgi::UsageError(what + " is >= 1 in a channel (" + v.dump() +
                                "); give --allow-reflectivity-ge-1 to accept it");
    rho.reflectivity[it->second] = c;
    rho.scale[it->second] = 1;
  }
}

// One frame into state (its lights) and rho (the reflectivities so far; state.rho a new copy where it changed).
void read_frame(const nlohmann::json& fr, const FrameNames& s, Frame& state, FrameReflectivity& rho) {
  bool changed = false;
  if (!fr.is_object()) throw hpcgi::UsageError("a frame is an object {\"lights\": {...}, \"reflectivity\": {...}}");
  for (const auto& [key, value] : fr.items()) {
    if (key == "lights") {
      read_lights(value, s, state);
    } else if (key == "reflectivity") {
      changed = true;
      read_reflectivity(value, s, rho);
    } else {
      throw hpcgi::UsageError("unknown key '" + key + "' (a frame has lights, reflectivity)");
    }
  }
  if (changed) state.rho = std::make_shared<const FrameReflectivity>(rho);
}

// Whether every entity has its scene reflectivity in rho.
bool scene_reflectivity(const std::vector<NamedEntity>& named, const FrameReflectivity& rho) {
  bool same = true;
  for (size_t e = 0; e < named.size(); ++e)
    same &= rho.scale[e] == 1 &&
            (!rho.reflectivity[e] || (named[e].uniform_reflectivity && *rho.reflectivity[e] == named[e].reflectivity));
  return same;
}

}  // namespace

std::vector<Frame> read_frames(const std::string& path, const Mesh& m, const std::vector<NamedEntity>& named,
                               bool allow_reflectivity_ge_1) {
  const nlohmann::json doc = parse_frames_file(path);
  if (!doc.is_object() || !doc.contains("frames") || !doc["frames"].is_array() || doc.size() != 1)
    throw hpcgi::UsageError(path + ": a frames file is one object {\"frames\": [frame, ...]}");
  FrameNames s{named, lights_of(named), {}, {}, std::vector<Rgb>(m.size()), allow_reflectivity_ge_1};
  for (size_t i = 0; i < m.size(); ++i) s.scene_rho[i] = m.patches[i].reflectivity;
  for (size_t l = 0; l < s.lights.size(); ++l) s.light_index[s.lights[l].name] = l;
  for (size_t e = 0; e < named.size(); ++e) s.entity_index[named[e].name] = e;
  const nlohmann::json& list = doc["frames"];
  if (list.size() > kMaxFrames)
    throw hpcgi::UsageError(path + ": " + std::to_string(list.size()) + " frames, more than " +
                            std::to_string(kMaxFrames) + " in one run");
  // At most: every frame's lights, and a copy of every entity's reflectivity for each frame that changes one.
  size_t changes = 0;
  for (const nlohmann::json& fr : list) changes += fr.is_object() && fr.contains("reflectivity");
  const double per_frame = double(sizeof(Frame) + s.lights.size() * sizeof(LightSetting));
  const double per_change = double(named.size()) * (sizeof(std::optional<Rgb>) + sizeof(double));
  hpcgi::require_host_memory(path + ": " + std::to_string(list.size()) + " frames",
                             double(list.size()) * per_frame + double(changes) * per_change);
  Frame state;
  state.lights.assign(s.lights.size(), LightSetting{});
  FrameReflectivity rho;
  rho.reflectivity.assign(named.size(), std::nullopt);
  rho.scale.assign(named.size(), 1.0);
  state.rho = std::make_shared<const FrameReflectivity>(rho);
  std::vector<Frame> frames;
  frames.reserve(list.size());
  for (size_t k = 0; k < list.size(); ++k) {
    try {
      read_frame(list[k], s, state, rho);
    } catch (const hpcgi::UsageError& e) {
      throw hpcgi::UsageError(path + ": frame " + std::to_string(k) + ": " + e.what());
    }
    state.scene_reflectivity = scene_reflectivity(named, rho);
    frames.push_back(state);
  }
  if (frames.empty()) throw hpcgi::UsageError(path + ": no frames");
  return frames;
}

std::vector<Frame> random_frames(size_t count, uint64_t seed, const std::vector<NamedEntity>& named) {
  const size_t k = lights_of(named).size();
  uint64_t s = seed * 0x9E3779B97F4A7C15ull + 1;
  auto uniform = [&s] {  // splitmix64, its top 53 bits as [0, 1)
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return double((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  };
  FrameReflectivity scene;
  scene.reflectivity.assign(named.size(), std::nullopt);
  scene.scale.assign(named.size(), 1.0);
  const auto rho = std::make_shared<const FrameReflectivity>(scene);
  std::vector<Frame> frames(count);
  for (Frame& f : frames) {
    f.rho = rho;
    f.lights.resize(k);
    for (LightSetting& l : f.lights) {
      l.intensity = 2 * uniform();
      for (double& c : l.colour) c = uniform();
    }
  }
  return frames;
}

Mesh frame_mesh(const Mesh& m, const std::vector<NamedEntity>& named, const Frame& f) {
  Mesh out = m;
  const std::vector<NamedEntity> lights = lights_of(named);
  const std::vector<Rgb> e = frame_emission(m, lights, f.lights);
  for (size_t i = 0; i < m.size(); ++i) out.patches[i].emission = e[i];
  for (size_t k = 0; k < named.size(); ++k)
    for (size_t i : named[k].patches) {
      if (f.rho->reflectivity[k]) out.patches[i].reflectivity = *f.rho->reflectivity[k];
      for (double& c : out.patches[i].reflectivity) c *= f.rho->scale[k];
    }
  return out;
}

}  // namespace radiosity::relight
