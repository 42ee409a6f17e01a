// The frames of `bin/radiosity relight`: a JSON file
//   {"frames": [
//      {"lights": {"light.1": {"intensity": 0.5, "rgb": [1, 0.6, 0.3]}}},
//      {"reflectivity": {"xyplane.2": [0.45, 0.45, 0.45]}},
//      {"reflectivity": {"room.1": {"scale": 0.9}}},
//      ...]}
// Each frame sets, for named lights, an intensity and an r, g, b colour (the light's emission is intensity × colour
// ⊙ the scene's emission of its patches) and, for named entities, a new reflectivity r, g, b for all its patches, or
// {"scale": f}: the scene's reflectivity of each of its patches times f (for entities whose patches differ). What a
// frame does not
// set stays as the frame before left it (the scene's values before the first frame). Names are those
// `bin/radiosity info` lists.
#pragma once
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "radiosity/relight/basis.hpp"
#include "radiosity/relight/entities.hpp"

namespace radiosity::relight {

// The reflectivity a frame's entities have: one entry per named entity.
struct FrameReflectivity {
  // The reflectivity a frame (this or an earlier one) gave all the entity's patches, or none (the scene's, which
  // may differ from patch to patch).
  std::vector<std::optional<Rgb>> reflectivity;
  std::vector<double> scale;  // its patches' scene reflectivity times this (1: none)
};

struct Frame {
  std::vector<LightSetting> lights;  // one per light, in the order of lights_of(named)
  // Shared by the frames between two changes of a reflectivity: a frame that changes none costs its lights alone.
  std::shared_ptr<const FrameReflectivity> rho;
  bool scene_reflectivity = true;    // every patch has the scene's reflectivity: the light basis serves the frame
};

// The most frames one run serves (--frames, --random-frames), and the largest frames file: the record holds every
// frame, and a frames file's JSON is held whole while it is read.
constexpr size_t kMaxFrames = 100000;
constexpr size_t kMaxFramesFileBytes = size_t(32) << 20;

// Reads and checks every frame before anything is computed. Refuses with hpcgi::UsageError, one line
// "FILE: frame K: reason" (K from 0; malformed JSON: the line, column and frame it is in): a file of more than
// kMaxFramesFileBytes or more than kMaxFrames frames, or whose frames would not fit in memory, not JSON (NaN and
// Infinity are not JSON), not {"frames": [...]}, an unknown key, an unknown light or entity name (the known ones are
// listed), a value that is not a number, negative or not finite, a colour that is not three numbers, a reflectivity
// >= 1 in a channel without allow_reflectivity_ge_1.
std::vector<Frame> read_frames(const std::string& path, const Mesh& m, const std::vector<NamedEntity>& named,
                               bool allow_reflectivity_ge_1);

// count frames of lights only: every light a random intensity in [0, 2) and colour in [0, 1)³ (a fixed generator
// seeded by seed: the same frames on every machine).
std::vector<Frame> random_frames(size_t count, uint64_t seed, const std::vector<NamedEntity>& named);

// The mesh with a frame's emission and reflectivity.
Mesh frame_mesh(const Mesh& m, const std::vector<NamedEntity>& named, const Frame& f);

}  // namespace radiosity::relight
