// RRV's transform semantics as a 3×4 affine matrix acting on column vectors; see transform.hpp.
#include "radiosity/scene/transform.hpp"

#include <cmath>

namespace radiosity {

namespace {
constexpr double kPi = 3.14159265358979323846;

void set_identity(double r[3][4]) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) r[i][j] = (i == j) ? 1.0 : 0.0;
}
}  // namespace

Transform::Transform() { set_identity(m_); }

Transform Transform::times(const double r[3][4]) const {
  Transform out;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      double s = (j == 3) ? m_[i][3] : 0.0;  // r's implicit last row (0 0 0 1) carries m's translation
      for (int k = 0; k < 3; ++k) s += m_[i][k] * r[k][j];
      out.m_[i][j] = s;
    }
  }
  return out;
}

Transform Transform::translated(const Vec3& d) const {
  double r[3][4];
  set_identity(r);
  r[0][3] = d.x;
  r[1][3] = d.y;
  r[2][3] = d.z;
  return times(r);
}

Transform Transform::scaled(const Vec3& s) const {
  double r[3][4];
  set_identity(r);
  r[0][0] = s.x;
  r[1][1] = s.y;
  r[2][2] = s.z;
  return times(r);
}

Transform Transform::rotated(double angle_deg, const Vec3& axis) const {
  const Vec3 a = axis * (angle_deg * kPi / 180.0 / axis.norm());
  double rx[3][4], ry[3][4], rz[3][4];
  set_identity(rx);
  set_identity(ry);
  set_identity(rz);
  rx[1][1] = std::cos(a.x), rx[1][2] = -std::sin(a.x), rx[2][1] = std::sin(a.x), rx[2][2] = std::cos(a.x);
  // The sign of y's sine is RRV's (left-handed about y), see the header.
  ry[0][0] = std::cos(a.y), ry[0][2] = -std::sin(a.y), ry[2][0] = std::sin(a.y), ry[2][2] = std::cos(a.y);
  rz[0][0] = std::cos(a.z), rz[0][1] = -std::sin(a.z), rz[1][0] = std::sin(a.z), rz[1][1] = std::cos(a.z);
  return times(rx).times(ry).times(rz);
}

Vec3 Transform::apply(const Vec3& p) const {
  return {m_[0][0] * p.x + m_[0][1] * p.y + m_[0][2] * p.z + m_[0][3],
          m_[1][0] * p.x + m_[1][1] * p.y + m_[1][2] * p.z + m_[1][3],
          m_[2][0] * p.x + m_[2][1] * p.y + m_[2][2] * p.z + m_[2][3]};
}

}  // namespace radiosity
