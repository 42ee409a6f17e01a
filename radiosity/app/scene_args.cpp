// Options every scene-reading subcommand shares, and `info`.
#include <omp.h>

#include <algorithm>
#include <cstdio>
#include <iostream>

#include "common/cli.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"
#include "common/one_line.hpp"
#include "common/record.hpp"
#include "common/timer.hpp"
#include "radiosity/app/commands.hpp"
#include "radiosity/relight/entities.hpp"

namespace radiosity::app {

void add_scene_options(CLI::App* cmd, SceneArgs& a) {
  cmd->add_option("scene", a.scene, "scene in RRV's XML format")->required()->check(CLI::ExistingFile);
  cmd->add_option("--divide", a.load.divide, "maximum patch area: larger triangles are split in four (RRV's rule)")
      ->check(hpcgi::positive_finite())->capture_default_str();
  cmd->add_flag("--allow-reflectivity-ge-1", a.load.allow_reflectivity_ge_1,
                "accept reflectivity >= 1 in a channel (RRV's room3.xml has lossless bulb barrels)");
  cmd->add_option("--threads", a.threads, "OpenMP threads (default: OMP_NUM_THREADS or all cores)")
      ->check(hpcgi::integer_in(1, 4096));
  hpcgi::add_record_options(cmd, a);
}

void add_memory_option(CLI::App* cmd, SceneArgs& a) {
  cmd->add_option("--max-memory-per-rank", a.max_memory_per_rank,
                  "refuse (exit 2, nothing written) a run in which one process, or one MPI rank, would hold more "
                  "than BYTES (e.g. 64M, 1.5G): its rows of the form factors, vectors and buffers; the message says "
                  "how many ranks would do")
      ->check(hpcgi::byte_size());
}

double SceneArgs::memory_limit() const {
  return max_memory_per_rank.empty() ? 0.0 : hpcgi::parse_bytes(max_memory_per_rank);
}

void check_files(const SceneArgs& a, std::vector<hpcgi::files::Output> outputs,
                 const std::vector<hpcgi::files::Output>& inputs) {
  hpcgi::files::require_input(a.scene, "scene file");
  std::vector<std::string> paths{a.scene};
  for (const std::string& mesh : scene_mesh_files(a.scene, a.load)) paths.push_back(mesh);  // teapot.obj
  for (const auto& f : inputs) {
    hpcgi::files::require_input(f.path, f.what);
    paths.push_back(f.path);
  }
  outputs.push_back({a.record_path, "--record", true});
  hpcgi::files::check_outputs(outputs, paths);
}

void require_rows_for_ranks(size_t patches, int ranks) {
  if (ranks > 1 && size_t(ranks) > patches)
    throw hpcgi::UsageError("the scene has " + std::to_string(patches) + " patch" + (patches == 1 ? "" : "es") + " for " +
                            std::to_string(ranks) + " MPI ranks: every rank needs a row of its own (run on at most " +
                            std::to_string(patches) + " ranks)");
}

Mesh load_scene(const SceneArgs& a, double* seconds) {
  hpcgi::check_threads(a.threads);
  if (a.threads > 0) omp_set_num_threads(a.threads);
  hpcgi::Timer t;
  Mesh m = load_rrv_scene(a.scene, a.load);
  if (m.size() == 0) throw hpcgi::UsageError(a.scene + ": the scene has no patches");
  if (seconds) *seconds = t.seconds();
  return m;
}

FormFactorMatrix read_form_factors(const FormFactorFile& file, const Mesh& m, const FormFactorRead& how) {
  return file.checked(m).read(how);
}

void add_info(CLI::App& app, InfoArgs& a) {
  CLI::App* cmd = app.add_subcommand("info", "load a scene and print its patches, lights and the memory a run needs");
  add_scene_options(cmd, a);
}

int run_info(const InfoArgs& a) {
  check_files(a, {}, {});
  double load_s = 0;
  const Mesh m = load_scene(a, &load_s);
  double area = 0, amin = 1e300, amax = 0, rho_max = 0;
  size_t emitters = 0;
  bool grey = true;
  for (const Patch& p : m.patches) {
    const double pa = p.area();
    area += pa;
    amin = std::min(amin, pa);
    amax = std::max(amax, pa);
    if (p.emission[0] > 0 || p.emission[1] > 0 || p.emission[2] > 0) ++emitters;
    for (int c = 0; c < 3; ++c) rho_max = std::max(rho_max, p.reflectivity[c]);
    grey = grey && p.emission[0] == p.emission[1] && p.emission[1] == p.emission[2] &&
           p.reflectivity[0] == p.reflectivity[1] && p.reflectivity[1] == p.reflectivity[2];
  }
  const double n = static_cast<double>(m.size());
  nlohmann::json rec = hpcgi::record::make("radiosity");
  rec["params"] = {{"command", "info"}, {"scene", a.scene}, {"divide", a.load.divide}};
  rec["result"] = {{"patches", m.size()},        {"entities", m.entities.size()}, {"emitting_patches", emitters},
                   {"total_area", area},         {"min_patch_area", amin},         {"max_patch_area", amax},
                   {"max_reflectivity", rho_max}, {"grey", grey},                  {"mesh_hash", mesh_hash(m)},
                   {"dense_ff_bytes", 4.0 * n * n}};
  // The names relight and web take: lights, then every entity with its reflectivity.
  nlohmann::json names = nlohmann::json::array();
  const std::vector<relight::NamedEntity> named = relight::named_entities(m);
  for (const relight::NamedEntity& e : named)
    names.push_back({{"name", e.name}, {"patches", e.patches.size()}, {"light", e.light}, {"emission", e.emission},
                     {"reflectivity", e.reflectivity},
                     {"uniform_reflectivity", e.uniform_reflectivity}});
  rec["result"]["named"] = names;
  rec["times_s"] = {{"load", load_s}};
  if (!a.quiet) {
    // Names and the path are shown terminal-safe (one_line): a name holding an escape sequence shows it as text.
    std::printf("%s: %zu patches in %zu entities (divide %g), %zu emitting, loaded in %.3f s\n",
                hpcgi::one_line(a.scene, 4096).c_str(),
                m.size(), m.entities.size(), a.load.divide, emitters, load_s);
    std::printf("  total area %.4g, patch areas %.3g .. %.3g, max reflectivity %.3g, %s\n", area, amin, amax,
                rho_max, grey ? "grey (all channels equal)" : "coloured");
    std::printf("  dense float32 form factors: %.3f GiB\n", 4.0 * n * n / (1 << 30));
    for (const bool light : {true, false})
      for (const relight::NamedEntity& e : named)
        if (e.light == light || !light) {
          if (light)
            std::printf("  light  %-20s %6zu patches, emission %g,%g,%g\n", hpcgi::one_line(e.name).c_str(), e.patches.size(),
                        e.emission[0], e.emission[1], e.emission[2]);
          else
            std::printf("  entity %-20s %6zu patches, reflectivity %g,%g,%g%s\n", hpcgi::one_line(e.name).c_str(), e.patches.size(),
                        e.reflectivity[0], e.reflectivity[1], e.reflectivity[2],
                        e.uniform_reflectivity ? "" : " (its first patch's; others differ)");
        }
  }
  hpcgi::record::emit(rec, a);
  return 0;
}

std::pair<int, int> parse_size(const std::string& s) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(s.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || x != 'x' || w < 1 || h < 1 || w > 16384 ||
      h > 16384)
    throw hpcgi::UsageError("--size must be WIDTHxHEIGHT with 1..16384 pixels each, got '" + s + "'");
  return {w, h};
}

}  // namespace radiosity::app
