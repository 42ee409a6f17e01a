// RRV's transform semantics as a 3×4 affine matrix acting on column vectors; see transform.hpp.
#include "radiosity/scene/transform.hpp"

#include <cmath>

namespace radiosity {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

Transform::Transform() {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) m_[i][j] = (i == j) ? 1.0 : 0.0;
}

Transform Transform::plane_rotation(int from, int to, double angle) {
  Transform r;
  r.m_[from][from] = r.m_[to][to] = std::cos(angle);
  r.m_[to][from] = std::sin(angle);
  r.m_[from][to] = -std::sin(angle);
  return r;
}

Transform Transform::times(const Transform& r) const {
  Transform out;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      double s = (j == 3) ? m_[i][3] : 0.0;  // r's implicit last row (0 0 0 1) carries this one's translation
      for (int k = 0; k < 3; ++k) s += m_[i][k] * r.m_[k][j];
      out.m_[i][j] = s;
    }
  }
  return out;
}

Transform Transform::translated(const Vec3& d) const {
  Transform r;
  r.m_[0][3] = d.x;
  r.m_[1][3] = d.y;
  r.m_[2][3] = d.z;
  return times(r);
}

Transform Transform::scaled(const Vec3& s) const {
  Transform r;
  r.m_[0][0] = s.x;
  r.m_[1][1] = s.y;
  r.m_[2][2] = s.z;
  return times(r);
}

Transform Transform::rotated(double angle_deg, const Vec3& axis) const {
  const Vec3 a = axis * (angle_deg * kPi / 180.0 / axis.norm());
  // The right-hand rule turns y towards z about x, z towards x about y, x towards y about z. RRV turns x towards
  // z about y: the opposite sense (see the header).
  return times(plane_rotation(1, 2, a.x)).times(plane_rotation(0, 2, a.y)).times(plane_rotation(0, 1, a.z));
}

Vec3 Transform::apply(const Vec3& p) const {
  return {m_[0][0] * p.x + m_[0][1] * p.y + m_[0][2] * p.z + m_[0][3],
          m_[1][0] * p.x + m_[1][1] * p.y + m_[1][2] * p.z + m_[1][3],
          m_[2][0] * p.x + m_[2][1] * p.y + m_[2][2] * p.z + m_[2][3]};
}

}  // namespace radiosity
