// A small software rasteriser that turns a solved scene into a picture: perspective projection, near-plane
// clipping, z-buffer, smooth shading of the radiosity, both sides of every patch drawn, black background.
#pragma once
#include <vector>

#include "radiosity/mesh.hpp"
#include "radiosity/render/camera.hpp"
#include "radiosity/render/image.hpp"

namespace radiosity {

struct RenderOptions {
  double exposure = 1;     // radiosity is multiplied by this before clamping to [0, 1]
  double gamma = 2.2;      // pixel = clamp(exposure * B, 0, 1)^(1 / gamma) as 8 bits
  bool flat = false;       // one colour per patch (shows the patches), instead of smooth shading
  double crease_deg = 30;  // smooth shading blends patches that face within this angle; see vertex_colours.hpp
};

// radiosity has one entry per patch of m. width and height are in 1..16384. Throws hpcgi::UsageError for a
// radiosity of the wrong length, a bad size, bad options or a camera that cannot look (eye at target, up along the
// view direction, fov outside (0, 180)). A NaN radiosity shows black.
Image render(const Mesh& m, const std::vector<Rgb>& radiosity, const Camera& cam, int width, int height,
             const RenderOptions& opt = {});

}  // namespace radiosity
