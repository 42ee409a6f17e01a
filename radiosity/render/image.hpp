// An 8-bit RGB picture, the renderer's output and the PNG writer's input.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

namespace radiosity {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // 3 bytes per pixel, row by row from the top row, left to right

  std::array<std::uint8_t, 3> at(int x, int y) const {
    const std::uint8_t* p = &rgb[3 * (static_cast<size_t>(y) * width + x)];
    return {p[0], p[1], p[2]};
  }
};

}  // namespace radiosity
