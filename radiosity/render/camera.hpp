// Where the picture is taken from: a pinhole camera and the --view spec that names one.
#pragma once
#include <string>

#include "radiosity/mesh.hpp"

namespace radiosity {

struct Camera {
  Vec3 eye, target;
  Vec3 up{0, 1, 0};
  // The angle across the shorter side of the picture, so that a view that fits the scene fits it in landscape and
  // portrait pictures alike.
  double fov_deg = 60;
};

// spec is one of
//   auto    outside the bounding box, looking at its centre from the front (+z), upper (+y), right (+x) side, far
//           enough that the whole box is in the picture (the default)
//   front   from +z, looking along -z at the centre, the whole box in the picture
//   top     from +y, looking down at the centre, +z (the front) at the bottom of the picture
//   inside  from the centre of the box, moved back towards +z half-way to the front wall, looking along -z with a
//           wide (90 degree) lens: for closed rooms, it shows the back wall, the side walls, floor and ceiling
//   ex,ey,ez:tx,ty,tz[:fov]   an explicit eye, target and field of view in degrees (default 60, 0 < fov < 180)
// The named views need a mesh of some extent. Anything else throws hpcgi::UsageError with a one-line message that
// lists these forms.
Camera parse_view(const std::string& spec, const Mesh& m);

}  // namespace radiosity
