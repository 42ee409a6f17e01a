// RRV's --divide rule: a triangle whose area is above the maximum patch area is split into four at its edge
// midpoints, again and again, until every piece is at or below the limit.
#pragma once
#include <cstddef>
#include <optional>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

// The patches of one entity, breadth-first like RRV's queue: the entity's triangles are queued in order, each
// one popped is either kept (area <= max_area) or replaced by its four pieces at the back of the queue. The
// pieces keep the orientation and colours of their parent; piece order is (v0 m01 m20), (v1 m12 m01),
// (v2 m20 m12), (m12 m20 m01) with mij the midpoint of vi and vj, as in RRV. max_area must be > 0.
// nullopt as soon as there would be more than max_patches pieces: a huge triangle (or one whose area overflows)
// against a small maximum area would otherwise take all memory before anything could refuse it.
std::optional<std::vector<Patch>> subdivide(const std::vector<Patch>& triangles, double max_area,
                                            size_t max_patches);

}  // namespace radiosity
