// The affine transforms of RRV's scene body (translate, scale, rotate; shear is a no-op), composed like the
// OpenGL matrix stack: a nested transform is multiplied on the right, so the innermost one acts first.
// Semantics follow RRV 2007 (TransformMatrix.cpp), not OpenGL, where the two differ; see rotate().
#pragma once
#include "radiosity/mesh.hpp"

namespace radiosity {

class Transform {
 public:
  Transform();  // identity

  // Both take all three components as given: RRV reads a missing dx/dy/dz as 0, so a scale that names one axis
  // collapses the other two. The caller decides the defaults; this class only composes.
  Transform translated(const Vec3& d) const;
  Transform scaled(const Vec3& s) const;

  // RRV's rotation: the axis is normalised, multiplied by the angle, and the three components are used as angles
  // about x, y and z, composed as Rx·Ry·Rz (so on a vertex, z acts first). This is an exact rotation about the axis
  // only when the axis is a coordinate axis; kept for fidelity. RRV's rotation about y turns the opposite way to
  // the right-hand rule (+z goes to -x at +90°); x and z follow the right-hand rule. The room walls of RRV's scenes
  // face inwards only with this convention. The axis must not be zero (the caller checks).
  Transform rotated(double angle_deg, const Vec3& axis) const;

  Vec3 apply(const Vec3& p) const;

 private:
  // The rotation by `angle` (radians) that turns coordinate axis `from` towards axis `to`.
  static Transform plane_rotation(int from, int to, double angle);
  Transform times(const Transform& r) const;  // *this · r
  double m_[3][4];
};

}  // namespace radiosity
