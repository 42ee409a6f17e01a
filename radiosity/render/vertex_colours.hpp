// Radiosity per patch corner for smooth (Gouraud) shading: a radiosity solution is constant per patch, and drawn
// that way it shows every patch edge. Like RRV's visualizer, each corner takes instead the area-weighted average of
// the patches that meet at that point, so neighbouring patches blend into each other.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

// Corner k of patch i gets sum(A_j B_j) / sum(A_j) over the patches j that have a vertex at the same position
// (within about 1e-9 of the largest coordinate) and face within crease_deg of patch i's direction. The crease keeps
// the corners of a room sharp: with crease_deg = 180 a floor corner would take the colour of both walls. Patches
// facing opposite ways (the two sides of a thin wall) never blend unless crease_deg = 180.
// radiosity has one entry per patch.
std::vector<std::array<Rgb, 3>> smooth_vertex_colours(const Mesh& m, const std::vector<Rgb>& radiosity,
                                                      double crease_deg);

// The same blend as weights, for a renderer that relights and blends itself (bin/radiosity web): corner 3i + k
// (corner k of patch i) is Σ weight[q] B[patch[q]] over q in [start[3i + k], start[3i + k + 1]), the weights
// A_j / Σ A_j (a corner without weight: its own patch, weight 1).
struct VertexWeights {
  std::vector<uint32_t> start, patch;
  std::vector<float> weight;
};
VertexWeights smooth_vertex_weights(const Mesh& m, double crease_deg);

}  // namespace radiosity
