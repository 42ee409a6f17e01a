// `bin/radiosity web`: one self-contained HTML page (radiosity/web/page.html, built into the program) that relights
// the scene from its light basis with WebGL: the mesh, the smooth-shading weights of every corner
// (render/vertex_colours.hpp) and the basis inline as base64, no network.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "common/files.hpp"
#include "common/cli.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/record.hpp"
#include "common/sha256.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/relight/basis_file.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/render/render.hpp"
#include "radiosity/render/vertex_colours.hpp"

namespace radiosity::app {
namespace {

using namespace radiosity::relight;

const char* const kPage =
#include "web_page.inc"
    ;

// Patches whose relit radiosity the page shows in its hidden element #relit (for tests).
constexpr size_t kProbePatches = 16;

std::string base64(const void* data, size_t bytes) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const unsigned char* p = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((bytes + 2) / 3 * 4);
  for (size_t i = 0; i < bytes; i += 3) {
    const uint32_t v = uint32_t(p[i]) << 16 | (i + 1 < bytes ? uint32_t(p[i + 1]) << 8 : 0) |
                       (i + 2 < bytes ? uint32_t(p[i + 2]) : 0);
    out += abc[v >> 18 & 63];
    out += abc[v >> 12 & 63];
    out += i + 1 < bytes ? abc[v >> 6 & 63] : '=';
    out += i + 2 < bytes ? abc[v & 63] : '=';
  }
  return out;
}

template <class T>
std::string base64(const std::vector<T>& v) {
  return base64(v.data(), v.size() * sizeof(T));
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
  return s;
}

// The template with each placeholder replaced in one pass: a value is never searched for placeholders again (a
// scene named "@DATA@.xml" puts that text in the title, nothing more).
std::string fill(const std::string& page, const std::vector<std::pair<std::string, std::string>>& values) {
  std::string out;
  for (size_t at = 0; at < page.size();) {
    bool replaced = false;
    for (const auto& [key, value] : values)
      if (page.compare(at, key.size(), key) == 0) {
        out += value, at += key.size(), replaced = true;
        break;
      }
    if (!replaced) out += page[at++];
  }
  return out;
}

std::string html_escape(const std::string& s) {
  std::string out = replace_all(replace_all(replace_all(s, "&", "&amp;"), "<", "&lt;"), ">", "&gt;");
  return replace_all(replace_all(out, "\"", "&quot;"), "'", "&#39;");
}

// The data block as JSON whose text holds no <, > or & (each written \u003c ...: inside a JSON string, the only
// place they can be): no scene name can close the <script> element or open a comment in it.
std::string script_json(const nlohmann::json& data) {
  const std::string text = data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return replace_all(replace_all(replace_all(text, "&", "\\u0026"), "<", "\\u003c"), ">", "\\u003e");
}

// "sha256-BASE64" of the text between the template's first `open` tag and the next `close`: what the CSP allows.
std::string csp_hash(const std::string& page, const std::string& open, const std::string& close) {
  const size_t from = page.find(open), to = page.find(close, from);
  if (from == std::string::npos || to == std::string::npos) throw std::logic_error("web page template: no " + open);
  const auto digest = hpcgi::sha256(std::string_view(page).substr(from + open.size(), to - from - open.size()));
  return "sha256-" + base64(digest.data(), digest.size());
}

}  // namespace

void add_web(CLI::App& app, WebArgs& a) {
  CLI::App* cmd = app.add_subcommand(
      "web", "write one self-contained HTML page (no network) that relights the scene from its light basis in WebGL: "
             "a slider and a colour picker per light, URL ?NAME=intensity,r,g,b&...");
  add_scene_options(cmd, a);
  cmd->add_option("--ff", a.ff, "form-factor file written by `bin/radiosity formfactors` for this scene")->required();
  cmd->add_option("-o,--output", a.out, "the HTML page to write")->required();
  cmd->add_option("--basis", a.basis, "light-basis file of `relight --basis`: read when it exists, else solved and written");
  cmd->add_option("--basis-tol", a.basis_tol, "relative residual of every light's solve")
      ->check(hpcgi::positive_finite())->capture_default_str();
  cmd->add_option("--view", a.view,
                  "the page's camera, orbiting about the vertical through its target: inside | auto | front | top | "
                  "ex,ey,ez:tx,ty,tz[:fov]")
      ->capture_default_str();
  cmd->add_option("--exposure", a.exposure, "initial exposure of the page (its slider moves it)")
      ->check(hpcgi::positive_finite())->capture_default_str();
}

int run_web(const WebArgs& a) {
  hpcgi::Timer total;
  check_files(a, {{a.out, "-o"}, {a.basis, "--basis"}}, {{a.ff, "--ff"}});
  double load_s = 0;
  const Mesh m = load_scene(a, &load_s);
  const size_t n = m.size();
  const std::vector<NamedEntity> lights = lights_of(named_entities(m));
  // the dense values, and with two or more lights their row blocks while the basis is solved (at most as many)
  hpcgi::require_host_memory("the light basis of " + std::to_string(n) + " patches (dense float32 form factors" +
                                 std::string(lights.size() > 1 ? " and their row blocks)" : ")"),
                             4.0 * double(n) * double(n) * (lights.size() > 1 ? 2 : 1));
  LightBasis basis;
  bool loaded = false;
  {
    const FormFactorFile file = FormFactorFile::open(a.ff).checked(m).require_dense();
    const FormFactorMatrix ff = read_form_factors(file, m);
    BasisOptions opt;
    opt.tol = a.basis_tol;
    opt.threads = a.threads;
    basis = load_or_solve_basis(a.basis, m, file, dense_float32_view(ff.dense_float32_values(), n), lights, opt, &loaded);
  }
  std::vector<float> positions;
  positions.reserve(9 * n);
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Patch& p : m.patches)
    for (const Vec3& v : p.v) {
      positions.insert(positions.end(), {float(v.x), float(v.y), float(v.z)});
      lo = {std::min(lo.x, v.x), std::min(lo.y, v.y), std::min(lo.z, v.z)};
      hi = {std::max(hi.x, v.x), std::max(hi.y, v.y), std::max(hi.z, v.z)};
    }
  const VertexWeights w = smooth_vertex_weights(m, RenderOptions{}.crease_deg);
  // The page orbits the camera about the vertical through its target, at the eye's distance and height.
  const Camera cam = parse_view(a.view, m);
  const double diag = (hi - lo).norm();
  nlohmann::json light_names = nlohmann::json::array();
  for (const std::string& l : basis.lights) light_names.push_back(l);
  const nlohmann::json data = {
      {"patches", n},
      {"lights", light_names},
      {"probe", std::min(n, kProbePatches)},
      {"exposure", a.exposure},
      {"camera", {{"target", {cam.target.x, cam.target.y, cam.target.z}},
                  {"radius", std::hypot(cam.eye.x - cam.target.x, cam.eye.z - cam.target.z)},
                  {"height", cam.eye.y},
                  {"angle", std::atan2(cam.eye.x - cam.target.x, cam.eye.z - cam.target.z)},
                  {"fov", cam.fov_deg},
                  {"near", 0.005 * diag},
                  {"far", 3 * diag}}},
      {"positions", base64(positions)},
      {"basis", base64(basis.packed)},
      {"weight_start", base64(w.start)},
      {"weight_patch", base64(w.patch)},
      {"weight_value", base64(w.weight)}};
  const std::string title = "Relight " + a.scene.substr(a.scene.find_last_of('/') + 1);
  const std::string page = fill(kPage, {{"@SCRIPT_HASH@", csp_hash(kPage, "<script>", "</script>")},
                                         {"@STYLE_HASH@", csp_hash(kPage, "<style>", "</style>")},
                                         {"@TITLE@", html_escape(title)},
                                         {"@PATCHES@", std::to_string(n)},
                                         {"@DATA@", script_json(data)}});
  {
    hpcgi::files::AtomicFile out(a.out);
    if (std::fwrite(page.data(), 1, page.size(), out.stream()) != page.size()) out.fail(std::strerror(errno));
    out.commit();
  }
  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "web"}, {"scene", a.scene}, {"patches", n}, {"ff_file", a.ff}, {"output", a.out}};
  rec["result"] = {{"lights", light_names},
                   {"page_bytes", page.size()},
                   {"basis", {{"loaded", loaded}, {"iterations", basis.iterations}, {"max_residual", basis.max_residual}}},
                   {"weights", w.patch.size()}};
  rec["times_s"] = {{"load", load_s}, {"basis", basis.seconds}, {"total", total.seconds()}};
  if (!a.quiet)
    std::printf("web: %s, %zu patches, %zu lights (%s): %s, %.2f MB (basis %s)\n", a.scene.c_str(), n, lights.size(),
                name_list(lights).c_str(), a.out.c_str(), double(page.size()) / 1e6, loaded ? "read" : "solved");
  hpcgi::record::emit(rec, a);
  return 0;
}

}  // namespace radiosity::app
