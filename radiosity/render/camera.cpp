// The named views and the explicit eye:target[:fov] form; see camera.hpp.
#include "radiosity/render/camera.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <vector>

#include "common/errors.hpp"

namespace radiosity {
namespace {

const double kPi = 3.14159265358979323846;

hpcgi::UsageError bad_view(const std::string& spec, const std::string& why = "") {
  return hpcgi::UsageError("view '" + spec + "'" + (why.empty() ? "" : ": " + why) +
                           ": expected auto, front, top, inside or ex,ey,ez:tx,ty,tz[:fov] (fov in degrees, "
                           "0 < fov < 180)");
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(s);
  while (std::getline(in, part, sep)) parts.push_back(part);
  if (!s.empty() && s.back() == sep) parts.push_back("");  // getline drops a trailing empty field
  return parts;
}

// A whole token as a finite number, or false.
bool parse_number(const std::string& s, double& out) {
  if (s.empty() || std::isspace(static_cast<unsigned char>(s[0]))) return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtod(s.c_str(), &end);
  return errno == 0 && end == s.c_str() + s.size() && std::isfinite(out);
}

bool parse_vec3(const std::string& s, Vec3& out) {
  const std::vector<std::string> c = split(s, ',');
  return c.size() == 3 && parse_number(c[0], out.x) && parse_number(c[1], out.y) && parse_number(c[2], out.z);
}

// Looking straight up or down, the default up (+y) gives no horizon; -z then puts the front at the bottom.
Vec3 up_for(const Vec3& dir) {
  const Vec3 f = dir.normalized();
  return std::abs(f.y) > 0.999 ? Vec3{0, 0, -1} : Vec3{0, 1, 0};
}

Camera explicit_view(const std::string& spec) {
  const std::vector<std::string> parts = split(spec, ':');
  Camera cam;
  if (parts.size() < 2 || parts.size() > 3 || !parse_vec3(parts[0], cam.eye) || !parse_vec3(parts[1], cam.target))
    throw bad_view(spec);
  if (parts.size() == 3 && (!parse_number(parts[2], cam.fov_deg) || cam.fov_deg <= 0 || cam.fov_deg >= 180))
    throw bad_view(spec, "bad fov");
  if ((cam.target - cam.eye).norm() == 0) throw bad_view(spec, "eye and target coincide");
  cam.up = up_for(cam.target - cam.eye);
  return cam;
}

}  // namespace

Camera parse_view(const std::string& spec, const Mesh& m) {
  if (spec != "auto" && spec != "front" && spec != "top" && spec != "inside") return explicit_view(spec);
  if (m.patches.empty()) throw bad_view(spec, "the mesh is empty");

  const double inf = std::numeric_limits<double>::infinity();
  Vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
  for (const Patch& p : m.patches)
    for (const Vec3& v : p.v) {
      lo = {std::min(lo.x, v.x), std::min(lo.y, v.y), std::min(lo.z, v.z)};
      hi = {std::max(hi.x, v.x), std::max(hi.y, v.y), std::max(hi.z, v.z)};
    }
  const Vec3 centre = (lo + hi) * 0.5, half = (hi - lo) * 0.5;
  const double radius = half.norm();  // of the sphere around the box
  if (!(radius > 0) || !std::isfinite(radius)) throw bad_view(spec, "the mesh has no extent");

  Camera cam;
  cam.target = centre;
  // At this distance the sphere around the box touches the cone of view, so the box is inside it.
  const double fit = radius / std::sin(0.5 * cam.fov_deg * kPi / 180);
  if (spec == "auto") {
    cam.eye = centre + Vec3{0.6, 0.5, 1}.normalized() * fit;
  } else if (spec == "front") {
    cam.eye = centre + Vec3{0, 0, fit};
  } else if (spec == "top") {
    cam.eye = centre + Vec3{0, fit, 0};
    cam.up = up_for(cam.target - cam.eye);
  } else {  // inside
    cam.fov_deg = 90;
    cam.eye = centre + Vec3{0, 0, 0.5 * half.z};
    cam.target = cam.eye - Vec3{0, 0, 1};
  }
  return cam;
}

}  // namespace radiosity
